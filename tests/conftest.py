import pytest

from tests.server_harness import client, running_server


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """A live server without the 3D view, shared by a test module."""
    with running_server(tmp_path_factory.mktemp("data")) as (base_url, app):
        yield base_url, app


@pytest.fixture
def http(server):
    """A client of the shared server; whatever a test changes is put back, also when it fails."""
    with client(server[0]) as c:
        before = c.get("/api/params").json()
        try:
            yield c
        finally:
            c.put("/api/params", json={"motion": before["motion"], "gait": before["gait"]})
            c.put("/api/path/axle", json={"axle_m": None})
            c.put("/api/sim/speed", json={"speed": 1.0})
            c.post("/api/sim/resume")
            c.put("/api/sim/drive", json={"drive": "model"})
