"""The 3D view shows the active engine's parameter folders and follows an engine switch."""

from __future__ import annotations

from tests.server_harness import client, running_server


def test_the_view_shows_the_active_engines_folders(tmp_path):
    with running_server(tmp_path, viewer=True) as (base_url, app), client(base_url) as http:
        viewer = app.state.services.viewer

        def shown() -> set[str]:
            return {f.label for f, _engines in viewer._folders if f.visible}

        behnke = shown()
        assert {"Swinging", "Balancing", "Steering (CA)"} <= behnke
        assert "PFS oscillators" not in behnke
        assert viewer._engine.value == "behnke"
        changed = http.patch("/api/params", json={"gait": {"engine": "pfs"}})
        assert changed.status_code == 200
        pfs = shown()
        assert "Swinging" not in pfs and {"PFS oscillators", "Steering (CA)", "Clock"} <= pfs
        assert viewer._engine.value == "pfs"
        http.post("/api/params/undo")  # the switch is a change like any other
        assert shown() == behnke and viewer._engine.value == "behnke"
