"""A recording import is checked as strictly as PUT /api/params (issue 18, item 9): each of the
tester's files is refused with a 422 in the one error shape that says where and what is allowed,
and nothing changes; what is accepted exports and reads back as it was."""

from __future__ import annotations

import copy
import json

import pytest

from tests.testing.server_harness import wait_for

HEADERS = {"content-type": "application/json"}


@pytest.fixture(scope="module")
def exported(server):
    """A real export of the session so far (at least a second of frames)."""
    from tests.testing.server_harness import client

    with client(server[0]) as http:
        wait_for(lambda: http.get("/api/recording").json()["frames"] > 50, "frames recorded")
        return http.get("/api/recording/export").json()


def _set(doc: dict, path: tuple, value) -> dict:
    bad = copy.deepcopy(doc)
    target = bad
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = value
    return bad


BIG = "1" + "0" * 400  # a 400-digit integer, written into the JSON text as it is

CASES = {
    "400-digit frame": (("columns", "frame", 0), "BIG", []),  # refused as the JSON is read
    "qpos beyond float32": (("columns", "qpos", 3, 2), 1e39, ["columns", "qpos", 3, 2]),
    "pulse 40000": (("columns", "ocr", 1, 0, 0), 40000, ["columns", "ocr", 1, 0, 0]),
    "pulse -5": (("columns", "ocr", 1, 2, 3), -5, ["columns", "ocr", 1, 2, 3]),
    "frame 1e30": (("columns", "frame", 2), 1e30, ["columns", "frame", 2]),
    "drive 1000": (("columns", "drive", 0), 1000, ["columns", "drive", 0]),
    "version 0": (("columns", "version", 0), 0, ["columns", "version", 0]),
    "a time as text": (("columns", "t_s", 0), "0.5", ["columns", "t_s", 0]),
    "a fractional frame": (("columns", "frame", 0), 2.5, ["columns", "frame", 0]),
    "format_version true": (("format_version",), True, ["format_version"]),
    "no columns": (("columns",), {}, ["columns", "frame"]),
    "an unknown column": (("columns", "speed"), [1.0], ["columns", "speed"]),
    "an unknown key": (("comment",), "hi", ["comment"]),
    "a bad event": (("events",), [{"t_s": 1.0, "kind": "explosion"}], ["events", 0, "kind"]),
    "frames miscounted": (("frames",), 7, ["frames"]),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_bad_recording_is_refused_and_changes_nothing(server, http, exported, case):
    path, value, loc = CASES[case]
    bad = _set(exported, path, 0 if value == "BIG" else value)
    text = json.dumps(bad)
    if value == "BIG":  # as the tester wrote it: digits, not a float
        text = text.replace('"frame": [0,', f'"frame": [{BIG},', 1)
        assert BIG in text
    before = http.get("/api/recording").json()["replay"]
    answer = http.post("/api/recording/import", content=text, headers=HEADERS)
    assert answer.status_code == 422, answer.text[:300]
    assert answer.headers["content-type"] == "application/json"
    problem = answer.json()["detail"][0]
    assert problem["loc"] == ["body", *loc] and problem["type"] == "invalid_recording", problem
    assert http.get("/api/recording").json()["replay"] == before  # no replay started


def test_the_parameter_documents_inside_are_checked_too(server, http, exported):
    version = next(iter(exported["params"]))
    bad = _set(exported, ("params", version, "motion", "a_p"), 5.0)
    answer = http.post("/api/recording/import", content=json.dumps(bad), headers=HEADERS)
    assert answer.status_code == 422
    problem = answer.json()["detail"][0]
    assert problem["loc"] == ["body", "params", version, "motion", "a_p"]
    assert "allowed" in problem["msg"]


def test_what_is_accepted_reads_back_as_it_was_and_every_view_of_it_works(http, exported):
    try:
        back = http.post("/api/recording/import", content=json.dumps(exported), headers=HEADERS)
        assert back.status_code == 200 and back.json()["origin"] == "file"
        assert http.get("/api/recording/frame/0").status_code == 200
        assert http.get("/api/recording/export.vcd").status_code == 200
        again = http.get("/api/recording/export").json()
        assert again["columns"] == exported["columns"] and again["params"] == exported["params"]
    finally:
        http.post("/api/recording/live")


def test_the_schema_says_what_the_server_takes(http):
    schema = http.get("/openapi.json").json()
    body = schema["paths"]["/api/recording/import"]["post"]["requestBody"]
    columns = body["content"]["application/json"]["schema"]["properties"]["columns"]
    assert set(columns["required"]) == {
        "frame", "t_s", "sim_t_s", "phase", "qpos", "ocr", "version", "drive"
    }  # fmt: skip
    assert columns["additionalProperties"] is False


def test_one_import_at_a_time_the_next_is_told_to_retry(server, http, exported):
    """24 imports of 16 MiB at once stalled the simulation and the API for 20-30 s (4.9 GB):
    while one is read, another is 429 with `Retry-After`; the first gone, the next is read."""
    import socket
    from urllib.parse import urlsplit

    address, importing = urlsplit(server[0]), server[1].state.services.importing
    first = socket.create_connection((address.hostname, address.port), timeout=10)
    try:  # an import whose body is still on its way: it holds the import
        first.sendall(
            b"POST /api/recording/import HTTP/1.1\r\nHost: 127.0.0.1\r\n"
            b"Content-Type: application/json\r\nContent-Length: 100000\r\n\r\n{"
        )
        wait_for(importing.locked, "the first import is being read")
        busy = http.post("/api/recording/import", json=exported)
        assert busy.status_code == 429 and busy.headers["retry-after"] == "2"
        assert busy.json()["detail"][0]["msg"] == (
            "another recording is being imported: try again when it is done"
        )
    finally:
        first.close()  # it leaves mid-upload: the import is free again
    wait_for(lambda: not importing.locked(), "the first import let go")
    try:
        back = http.post("/api/recording/import", json=exported)
        assert back.status_code == 200 and back.json()["origin"] == "file"
    finally:
        http.post("/api/recording/live")
