"""Attacks from other sites on a real server, each refused with nothing changed: simple (no-cors)
POSTs, cross-origin WebSockets, foreign Host names (DNS rebinding), wrong content types."""

import json
import socket

import pytest
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

EVIL = "http://evil.example"
STATE_CHANGING = [
    "/api/import",
    "/api/presets/paper/load",
    "/api/params/undo",
    "/api/params/redo",
    "/api/sim/reset",
    "/api/sim/pause",
    "/api/sim/resume",
    "/api/sim/step",
    "/api/path/anchor",
    "/api/jobs/axle-fit",
]


def ws_url(base_url: str) -> str:
    return base_url.replace("http://", "ws://") + "/ws/scope"


def observable(http) -> tuple:
    state = http.get("/api/state").json()
    return http.get("/api/params").json(), state["paused"], state["resets"]


@pytest.mark.parametrize("path", STATE_CHANGING)
@pytest.mark.parametrize(
    "headers",
    [
        {"origin": EVIL, "content-type": "text/plain"},  # fetch(url, {mode: "no-cors", body})
        {"origin": EVIL},  # a bodiless no-cors POST
        {"origin": "null"},  # a sandboxed frame or a file:// page
        {"sec-fetch-site": "cross-site", "content-type": "application/json"},
        {"sec-fetch-site": "same-site"},  # another port of the same host
    ],
)
def test_a_cross_site_post_is_refused_and_changes_nothing(http, path, headers):
    http.patch("/api/params", json={"motion": {"a_p": 0.02}})  # something to undo
    before = observable(http)
    body = json.dumps({"motion": {"a_p": 0.11}, "gait": {}})
    response = http.post(path, content=body, headers=headers)
    assert response.status_code == 403, response.text
    error = response.json()["detail"][0]
    assert error["type"] in ("cross_origin", "cross_site") and "refused" in error["msg"]
    assert observable(http) == before


@pytest.mark.parametrize("path", ["/api/import", "/api/sim/pause", "/api/params/undo"])
@pytest.mark.parametrize(
    "media", ["text/plain", "application/x-www-form-urlencoded", "multipart/form-data"]
)
def test_state_changing_requests_take_only_json(http, path, media):
    before = observable(http)
    response = http.post(path, content=b'{"motion": {}}', headers={"content-type": media})
    assert response.status_code == 415
    assert "allowed: application/json" in response.json()["detail"][0]["msg"]
    assert observable(http) == before


def paused_soon(http, expected: bool) -> bool:
    """The sim thread takes a command at its next frame: read its state until it shows."""
    for _ in range(1000):
        if http.get("/api/state").json()["paused"] is expected:
            return True
    return False


def test_a_same_origin_page_and_a_plain_client_may_change_things(http, server):
    origin = server[0]
    assert http.post("/api/sim/pause", headers={"origin": origin}).status_code == 200
    assert paused_soon(http, True)
    same = {"origin": origin, "sec-fetch-site": "same-origin"}
    assert http.post("/api/sim/resume", headers=same).status_code == 200
    assert paused_soon(http, False)


@pytest.mark.parametrize("host", ["evil.example", "evil.example:80", "localhost.evil.example"])
def test_a_foreign_host_name_is_refused(http, host):
    """DNS rebinding: a page of evil.example whose name now points at 127.0.0.1."""
    for method, path in (("GET", "/api/params"), ("POST", "/api/sim/pause"), ("GET", "/")):
        response = http.request(method, path, headers={"host": host})
        assert response.status_code == 400, (method, path)
        assert response.json()["detail"][0]["type"] == "host_not_allowed"
    assert http.get("/api/state").json()["paused"] is False


@pytest.mark.parametrize("host", ["localhost", "127.0.0.1", "[::1]", "192.168.1.20"])
def test_loopback_names_and_addresses_are_served(http, server, host):
    port = server[0].rsplit(":", 1)[1]
    assert http.get("/api/health", headers={"host": f"{host}:{port}"}).status_code == 200


@pytest.mark.parametrize(
    ("origin", "host"),
    [(EVIL, None), ("http://127.0.0.1:1", None), ("null", None), (None, "evil.example")],
)
def test_a_foreign_websocket_is_refused(server, origin, host):
    port = int(server[0].rsplit(":", 1)[1])
    url = ws_url(server[0]).replace("127.0.0.1", host or "127.0.0.1")
    sock = socket.create_connection(("127.0.0.1", port))  # evil.example "resolves" to us
    with pytest.raises(InvalidStatus) as refused:
        with connect(url, sock=sock, origin=origin, open_timeout=10):
            pass
    assert refused.value.response.status_code in (400, 403)


def test_the_scope_socket_serves_its_own_page_and_plain_clients(server):
    for origin in (server[0], None):
        with connect(ws_url(server[0]), origin=origin, open_timeout=10) as ws:
            assert "channels" in json.loads(ws.recv(timeout=10))


def test_the_page_is_served_to_links_from_other_sites(http):
    response = http.get("/", headers={"sec-fetch-site": "cross-site"})
    assert response.status_code == 200 and "<html" in response.text.lower()
