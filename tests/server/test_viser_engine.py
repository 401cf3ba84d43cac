"""The 3D view shows the active engine's parameter folders and follows an engine switch; a taken
port moves it on, and the server says where."""

from __future__ import annotations

import socket

import httpx

from app.robots.model import RobotModel
from tests.testing.server_harness import client, running_server


def test_the_view_shows_the_active_engines_folders(tmp_path):
    with running_server(tmp_path, viewer=True) as (base_url, app), client(base_url) as http:
        viewer = app.state.services.viewer

        def shown() -> set[str]:
            return {f.label for f, _engines in viewer.parameters.folders if f.visible}

        behnke = shown()
        assert {"Swinging", "Balancing", "Steering (CA)"} <= behnke
        assert "PFS oscillators" not in behnke
        assert viewer.parameters.engine.value == "behnke"
        changed = http.patch("/api/params", json={"gait": {"engine": "pfs"}})
        assert changed.status_code == 200
        pfs = shown()
        assert "Swinging" not in pfs and {"PFS oscillators", "Steering (CA)", "Clock"} <= pfs
        assert viewer.parameters.engine.value == "pfs"
        http.post("/api/params/undo")  # the switch is a change like any other
        assert shown() == behnke and viewer.parameters.engine.value == "behnke"


def test_a_taken_port_moves_the_view_on_and_the_health_names_the_port_in_use(tmp_path, capfd):
    """The asked 3D view port is taken: viser takes the next free one, the server says so on
    stderr, and `/api/health` (which the page embeds the view from) names the port in use."""
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        asked = taken.getsockname()[1]
        with (
            running_server(tmp_path, viewer=True, viser_port=asked) as (base_url, _app),
            client(base_url) as http,
        ):
            shown = http.get("/api/health").json()["viser_port"]
            assert shown != asked
            page = httpx.get(f"http://127.0.0.1:{shown}/", timeout=10)
            assert page.status_code == 200 and "<html" in page.text.lower()
    assert f"port {asked} is taken; the 3D view alone is on {shown}" in capfd.readouterr().err


def test_the_view_draws_from_its_own_copy_of_the_model(tmp_path):
    """mjviser's scene sets the model's display scales (frames x 0.3, ...): drawn from the
    simulation's own model, each switch back to a robot seen before shrank them again, in the
    simulation thread's model. The view keeps to a copy; a rebuild leaves the model as built."""
    built = RobotModel.load().model.vis.scale.framewidth
    with running_server(tmp_path, viewer=True) as (_base_url, app):
        viewer, sim = app.state.services.viewer, app.state.services.sim
        assert sim.model.vis.scale.framewidth == built
        viewer._rebuild_scene(sim.model)
        viewer._rebuild_scene(sim.model)
        assert sim.model.vis.scale.framewidth == built
        assert viewer.scene.mj_model is not sim.model
