import pytest

from app.params.document import ParameterSet
from app.server.param_store import ParameterStore
from app.server.sim.sim_thread import SimThread
from tests.testing.firmware_support import emulator, preset, served_on_a_pty
from tests.testing.server_harness import client, running_server


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist reads the groups
def pytest_collection_modifyitems(items):
    """`scripts/test.sh` runs the tests of the modules that open Chromium (they import
    `CHROMIUM` from tests/testing/server_harness.py; marked `browser` here) alone, and the rest on
    every core (`-n auto --dist loadgroup`), a module's tests on one worker (its module fixtures
    are made once)."""
    for item in items:
        module = item.module
        if hasattr(module, "CHROMIUM"):
            item.add_marker(pytest.mark.browser)
        item.add_marker(pytest.mark.xdist_group(module.__name__))


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


@pytest.fixture
def sim_thread():
    """(simulation thread, its store) walking `tuned` at a_p 0.06, running until the test ends."""
    store = ParameterStore(ParameterSet.from_dict(preset("tuned", a_p=0.06)))
    sim = SimThread(store)
    sim.start()
    try:
        yield sim, store
    finally:
        sim.stop()


@pytest.fixture
def robot_on_a_pty():
    """The emulated robot (paper) served on a pseudo-terminal until the test ends: its path."""
    with emulator(preset("paper")) as mcu, served_on_a_pty(mcu) as port:
        yield port
