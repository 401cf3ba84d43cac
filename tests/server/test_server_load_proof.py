"""Load-proof serving on a real server: body limits, short errors, one JSON rule, true 405s,
reserved preset names, stale temp files, a real-time factor that restarts, shared scope frames."""

import json
import os
import time

import pytest
from websockets.sync.client import connect

from tests.testing.server_harness import client, running_server

JSON = {"content-type": "application/json"}


@pytest.mark.parametrize(
    ("method", "path", "size"),
    [
        ("PUT", "/api/params", 20 * 1024 * 1024),
        ("PATCH", "/api/params", 17 * 1024),
        ("POST", "/api/import", 65 * 1024),
        ("PUT", "/api/presets/big", 17 * 1024),
        ("POST", "/api/sim/pause", 17 * 1024),
    ],
)
def test_a_body_over_the_limit_gets_a_short_413_and_changes_nothing(http, method, path, size):
    before = http.get("/api/params").json()
    body = b'{"motion": {"a_p": 0.1}, "pad": "' + b"x" * size + b'"}'
    response = http.request(method, path, content=body, headers=JSON)
    assert response.status_code == 413
    assert len(response.content) < 300
    assert response.json()["detail"][0]["type"] == "body_too_large"
    assert http.get("/api/params").json() == before


def test_a_streamed_body_without_length_is_counted(http):
    before = http.get("/api/params").json()

    def chunks():
        yield b'{"motion": {"a_p": 0.1}, "pad": "'
        for _ in range(64):
            yield b"x" * 1024
        yield b'"}'

    response = http.patch("/api/params", content=chunks(), headers=JSON)
    assert response.status_code == 413 and "16384 bytes" in response.text
    assert http.get("/api/params").json() == before


def test_errors_echo_little_of_the_input(http):
    huge_value = json.dumps({"motion": {"a_p": "x" * 15000}})
    many_keys = json.dumps({"motion": {f"k{i}": i for i in range(1000)}})
    huge_key = json.dumps({"motion": {"k" * 15000: 1}})
    for body in (huge_value, many_keys, huge_key):
        response = http.patch("/api/params", content=body, headers=JSON)
        assert response.status_code == 422
        assert len(response.content) < 3000, len(response.content)
        assert set(response.json()) == {"detail", "message", "version"}
        assert all(set(item) == {"loc", "msg", "type"} for item in response.json()["detail"])
    assert "more" in http.patch("/api/params", content=many_keys, headers=JSON).json()["message"]


@pytest.mark.parametrize(
    ("method", "path"), [("PATCH", "/api/params"), ("PUT", "/api/params"), ("POST", "/api/import")]
)
def test_duplicate_keys_are_refused_everywhere_naming_the_key(http, method, path):
    before = http.get("/api/params").json()
    doc = json.dumps({"motion": before["motion"], "gait": before["gait"]})
    body = doc.replace('"a_p": ', '"a_p": 0.2, "a_p": ', 1)
    response = http.request(method, path, content=body, headers=JSON)
    assert response.status_code == 422
    assert "duplicate key 'a_p'" in response.json()["message"]
    if path != "/api/import":  # a JSON body: the parser's own words, the body its place
        assert response.json()["detail"][0]["loc"] == ["body"]
        assert response.json()["message"].startswith("JSON decode error: duplicate key")
    assert http.get("/api/params").json() == before


@pytest.mark.parametrize(
    ("method", "path", "allow"),
    [
        ("OPTIONS", "/api/import", "POST"),
        ("GET", "/api/import", "POST"),
        ("POST", "/api/sim/speed", "PUT"),
        ("DELETE", "/api/params", "GET, PUT, PATCH"),
        ("POST", "/api/presets/paper", "GET, PUT, DELETE"),
        ("PUT", "/api/scope", "GET"),
    ],
)
def test_a_wrong_method_gets_405_with_the_true_allow(http, method, path, allow):
    response = http.request(method, path, headers=JSON)
    assert response.status_code == 405
    assert response.headers["allow"] == allow
    assert response.json()["detail"][0]["type"] == "method_not_allowed"


def test_an_unknown_api_path_is_a_404_of_the_api_not_the_page(http):
    for path in ("/api/nothing", "/api/params/extra/deep", "/api"):
        response = http.get(path)
        assert response.status_code == 404 and response.json()["detail"][0]["type"] == "not_found"
    assert http.get("/").status_code == 200  # the page is still at /


@pytest.mark.parametrize("name", ["diff", "current", "Diff"])
def test_route_names_are_reserved_for_presets(http, name):
    response = http.put(f"/api/presets/{name}")
    if name == "diff":  # the diff's own path: it answers GET only
        assert response.status_code == 405 and response.headers["allow"] == "GET"
    else:
        assert response.status_code == 422 and "reserved" in response.json()["message"]
    names = [p["name"] for p in http.get("/api/presets").json()["presets"]]
    assert name not in names


def test_a_preset_file_named_diff_is_reported_not_shadowed(http, server):
    presets = server[1].state.services.presets.directory
    presets.mkdir(parents=True, exist_ok=True)
    (presets / "diff.json").write_text(json.dumps({"name": "diff"}))
    try:
        problems = http.get("/api/presets").json()["problems"]
        assert any(p["file"] == "diff.json" for p in problems)
    finally:
        (presets / "diff.json").unlink()


def test_stale_temp_files_of_a_crashed_save_are_removed_at_start(tmp_path):
    presets = tmp_path / "presets"
    presets.mkdir()
    stale, fresh = presets / ".brisk.x1.tmp", presets / ".brisk.x2.tmp"
    for path in (stale, fresh):
        path.write_text('{"half": ')
    old = time.time() - 3600  # a save killed an hour ago
    os.utime(stale, (old, old))
    with running_server(tmp_path) as (base_url, _app), client(base_url) as http:
        assert http.get("/api/presets").json()["problems"] == []
    assert not stale.exists()
    assert fresh.exists()  # may belong to a save running now in another process


def test_the_real_time_factor_restarts_with_a_reset_and_is_never_negative(http):
    for _ in range(3):
        assert http.post("/api/sim/reset").status_code == 200
        start = http.get("/api/state").json()["frame"]
        seen = []
        while True:  # read the state as often as possible while the simulation restarts
            state = http.get("/api/state").json()
            seen.append(state["rtf"])
            if state["resets"] and state["frame"] > start + 25:
                break
        assert all(rtf is None or rtf >= 0 for rtf in seen), seen


def test_every_client_gets_the_same_frame_text(http, server):
    assert http.post("/api/sim/pause").status_code == 200
    try:
        url = server[0].replace("http://", "ws://") + "/ws/scope"
        with connect(url, open_timeout=10) as a, connect(url, open_timeout=10) as b:
            http.post("/api/sim/step")
            text_a, text_b = a.recv(timeout=10), b.recv(timeout=10)
        assert text_a == text_b
        first = http.get("/api/scope", params={"frames": 250})
        second = http.get("/api/scope", params={"frames": 250})
        assert first.content == second.content  # the same frames: the same shared answer
        frames = first.json()["frames"]
        assert frames[-1] == json.loads(text_a) and len(frames) <= 250
    finally:
        http.post("/api/sim/resume")


def test_openapi_documents_every_status_and_the_import_body(http):
    spec = http.get("/openapi.json").json()
    assert {"application/json", "application/yaml"} <= set(
        spec["paths"]["/api/import"]["post"]["requestBody"]["content"]
    )
    for path, operations in spec["paths"].items():
        if not path.startswith("/api/"):
            continue
        for method, operation in operations.items():
            statuses = set(operation["responses"])
            assert {"400", "403", "413", "415"} <= statuses, (method, path)
            for status in statuses - {"200", "201", "202"}:
                schema = operation["responses"][status]["content"]["application/json"]["schema"]
                assert schema == {"$ref": "#/components/schemas/ErrorBody"}, (method, path, status)
    put = spec["paths"]["/api/params"]["put"]["responses"]
    assert {"409", "412", "422"} <= set(put)


@pytest.mark.parametrize(
    "body",
    [
        ("items:\n" + "- 1\n" * 16000).encode(),  # once 1.6 s of the GIL in PyYAML's scanner
        "".join(f"k{i}: {i}\n" for i in range(6000)).encode(),
        ("a: " + "[" * 7 + "1, " * 20000 + "]" * 7).encode(),
    ],
    ids=["long list", "many keys", "flow nesting"],
)
def test_a_big_yaml_import_is_refused_by_counting_not_by_checking(http, body):
    before = http.get("/api/params").json()
    response = http.post("/api/import", content=body[:65536], headers={"content-type": "text/yaml"})
    assert response.status_code == 422
    assert "more than 1000 keys and values" in response.json()["message"]
    assert http.get("/api/params").json() == before
