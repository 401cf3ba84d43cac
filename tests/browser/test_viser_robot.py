"""The 3D view follows a switch of robots (docs/DESIGN.md §7): with a browser watching, the
scene is built again from the new robot's model, and the view's refresh goes on without errors;
a push is drawn as an arrow onto the trunk along the push, for a while (§15)."""

from __future__ import annotations

import logging

import numpy as np
from playwright.sync_api import sync_playwright

from tests.testing.server_harness import CHROMIUM, CHROMIUM_ARGS, client, running_server, wait_for


def test_the_view_draws_the_robot_switched_to_and_a_push(tmp_path, caplog):
    caplog.set_level(logging.ERROR)
    with (
        running_server(tmp_path, viewer=True) as (base_url, app),
        client(base_url) as http,
        sync_playwright() as p,
    ):
        services = app.state.services
        viewer = services.viewer
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        page = browser.new_page(viewport={"width": 900, "height": 700})
        page.goto(f"http://127.0.0.1:{http.get('/api/health').json()['viser_port']}/")
        wait_for(lambda: viewer.server.get_clients(), "the browser watches the 3D view")
        artro_scene = viewer.scene
        assert http.put("/api/robot", json={"name": "micro"}).status_code == 200
        wait_for(
            lambda: viewer._model is services.sim.model and viewer.scene is not artro_scene,
            "the view drew the micro robot",
        )
        assert services.sim.robot.name == "micro"
        page.screenshot(path=str(tmp_path / "micro-3d.png"))  # to look at
        http.post("/api/params/undo")
        wait_for(lambda: services.sim.robot.name == "artro", "back on ArtRo")
        wait_for(lambda: viewer._model is services.sim.model, "the view drew ArtRo again")

        # a push is drawn as an arrow onto the trunk, along the push, for a while
        assert http.post("/api/sim/push", json={"impulse_n_s": 0.3, "direction_deg": 90}).is_success
        wait_for(lambda: viewer._push.visible, "the push drawn")
        push = services.sim.status().push
        shaft = viewer._push.points[0]  # (tail, tip)
        np.testing.assert_allclose(shaft[1], [push.x_m, push.y_m, push.z_m], atol=1e-6)
        along = shaft[1] - shaft[0]
        heading = np.degrees(np.arctan2(along[1], along[0]))
        assert abs((heading - push.direction_deg + 180.0) % 360.0 - 180.0) < 0.01
        page.screenshot(path=str(tmp_path / "push-3d.png"))  # to look at
        wait_for(lambda: not viewer._push.visible, "the arrow goes after 1.5 s")
        browser.close()
    assert not [r for r in caplog.records if "viewer refresh failed" in r.getMessage()]
