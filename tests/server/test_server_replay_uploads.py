"""What a hostile client tried on a real server (issue 18, item 11): resume or step while a replay
is shown would run the live simulation under the replay's views (409 now, nothing runs); a client
that drops in the middle of an upload leaves no traceback in the log."""

from __future__ import annotations

import logging
import socket
from urllib.parse import urlsplit

import pytest

from tests.testing.server_harness import wait_for


def test_resume_and_step_are_refused_while_a_replay_is_shown(http):
    wait_for(lambda: http.get("/api/recording").json()["frames"] > 30, "frames recorded")
    try:
        assert http.post("/api/recording/replay", json={}).status_code == 200
        wait_for(lambda: http.get("/api/state").json()["paused"], "the replay pauses")
        frame = http.get("/api/state").json()["frame"]
        for action in ("resume", "step"):
            refused = http.post(f"/api/sim/{action}")
            assert refused.status_code == 409, refused.text
            assert refused.json()["detail"][0]["type"] == "replaying"
            assert "go back to live" in refused.json()["message"]
        # a command after them has been taken: so have they, if they were sent at all
        http.put("/api/sim/speed", json={"speed": 2.0})
        wait_for(lambda: http.get("/api/state").json()["speed"] == 2.0, "the speed taken")
        state = http.get("/api/state").json()
        assert state["paused"] and state["frame"] == frame, "the live simulation ran"
        assert http.post("/api/sim/pause").status_code == 200  # harmless: still allowed
    finally:
        http.post("/api/recording/live")
    wait_for(lambda: not http.get("/api/state").json()["paused"], "live again")
    assert http.post("/api/sim/step").status_code == 200  # live: step as before


class Records(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)


@pytest.fixture
def server_log():
    """Every record of uvicorn's error log and of the request gate (debug on) during the test."""
    handler = Records()
    loggers = [
        logging.getLogger(name) for name in ("uvicorn.error", "app.server.http.request_gate")
    ]
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.addHandler(handler)
    loggers[1].setLevel(logging.DEBUG)
    yield handler.records
    for logger, level in zip(loggers, levels, strict=True):
        logger.removeHandler(handler)
        logger.setLevel(level)


@pytest.mark.parametrize(
    ("path", "media"),
    [("/api/recording/import", "application/json"), ("/api/import", "application/yaml")],
)
def test_a_client_that_drops_mid_upload_leaves_no_traceback(server, http, server_log, path, media):
    url = urlsplit(server[0])
    head = (
        f"POST {path} HTTP/1.1\r\nHost: {url.netloc}\r\nContent-Type: {media}\r\n"
        f"Content-Length: 40000\r\n\r\n"
    )
    with socket.create_connection((url.hostname, url.port)) as raw:
        raw.sendall(head.encode() + b'{"format": "artro-recording", "columns": {' + b" " * 2000)
    # the connection is gone with 37 KiB still to come
    wait_for(
        lambda: any(
            "left before its body" in r.getMessage() or r.levelno >= logging.WARNING
            for r in server_log
        ),
        "the server noticed the client leave",
    )
    errors = [r.getMessage() for r in server_log if r.levelno >= logging.WARNING]
    assert errors == [], errors
    assert not any(r.exc_info for r in server_log)
    assert http.get("/api/health").json()["status"] == "ok"
