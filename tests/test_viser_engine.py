"""The 3D view shows the active engine's parameter folders and follows an engine switch; a taken
port moves it on, and the server says where."""

from __future__ import annotations

import socket

import httpx

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
