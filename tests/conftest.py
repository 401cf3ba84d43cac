import pytest

from tests.server_harness import client, running_server


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """A live server without the 3D view, shared by a test module."""
    with running_server(tmp_path_factory.mktemp("data")) as (base_url, app):
        yield base_url, app


@pytest.fixture
def http(server):
    with client(server[0]) as c:
        yield c
