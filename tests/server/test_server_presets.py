"""Presets, diff, export and import through the real server."""

import json

import pytest
import yaml

from app.robots import load_description

PRESET_NAMES_BAD = ["..", "a b", "x" * 65, ".hidden", "a..b", "con:x"]


def test_the_server_starts_with_the_default_preset_and_lists_the_builtins(http):
    # a new user sees a robot that walks, and keeps walking on a robot that is not the model
    started = http.get("/api/params").json()
    assert started["name"] == "robust-3" and started["gait"]["tilt"]["enabled"]
    assert started["name"] == load_description("artro").default_preset
    presets = {p["name"]: p for p in http.get("/api/presets").json()["presets"]}
    assert presets["paper"]["builtin"] and presets["tuned"]["builtin"]
    assert presets["robust"]["robot"] == "artro" and presets["micro-tuned"]["robot"] == "micro"
    assert presets["robust"]["builtin"]  # the older default stays loadable by name
    assert http.put("/api/presets/tuned").status_code == 422  # read-only


def test_save_list_get_load_diff_delete(http):
    http.post("/api/presets/paper/load")
    http.patch("/api/params", json={"motion": {"a_p": 0.05}, "gait": {"swing": {"v": 2.4}}})
    saved = http.put("/api/presets/brisk")
    assert saved.status_code == 201 and saved.json()["name"] == "brisk"
    names = [p["name"] for p in http.get("/api/presets").json()["presets"]]
    assert names[0] == "paper" and "brisk" in names
    assert http.get("/api/presets/brisk").json()["gait"]["swing"]["v"] == 2.4
    diff = http.get("/api/presets/diff", params={"a": "paper", "b": "brisk"}).json()
    fields = {d["field"]: (d["a"], d["b"]) for d in diff["differences"]}
    assert fields == {"motion.a_p": (0.0, 0.05), "swing.v": (2.0, 2.4)}
    loaded = http.post("/api/presets/paper/load").json()
    assert loaded["motion"]["a_p"] == 0.0 and loaded["name"] == "paper"
    assert http.post("/api/presets/brisk/load").json()["gait"]["swing"]["v"] == 2.4
    assert http.delete("/api/presets/brisk").status_code == 200
    assert http.get("/api/presets/brisk").status_code == 404
    http.post("/api/presets/paper/load")


def test_builtin_and_bad_names_are_refused_and_nothing_is_written(http, server):
    before = http.get("/api/presets").json()["presets"]
    assert http.put("/api/presets/paper").status_code == 422
    assert "read-only" in http.delete("/api/presets/paper").text
    assert http.put("/api/presets/current").status_code == 422
    said = http.put("/api/presets/_x").json()["message"]  # the rule in words, not its regex
    assert (
        said == "path.name: a preset name is 1 to 64 characters: letters, digits, '_', '.' and "
        "'-', starting with a letter or digit, without '..' and not ending in '.'; got '_x'"
    )
    for name in PRESET_NAMES_BAD:
        response = http.put(f"/api/presets/{name}")
        assert response.status_code in (404, 405, 422), name
    # path traversal does not reach outside the presets directory
    assert http.get("/api/presets/..%2F..%2Fetc%2Fpasswd").status_code in (404, 422)
    assert http.get("/api/presets/nothing-here").status_code == 404
    assert http.get("/api/presets").json()["presets"] == before


@pytest.mark.parametrize("fmt", ["json", "yaml"])
def test_export_reimports_to_the_same_parameters(http, fmt):
    http.patch(
        "/api/params", json={"motion": {"a_r": 0.05, "ca": 0.02}, "gait": {"load": {"v": 2.5}}}
    )
    before = http.get("/api/params").json()
    response = http.get("/api/export", params={"format": fmt})
    assert response.status_code == 200
    assert "attachment" in response.headers["content-disposition"]
    doc = json.loads(response.text) if fmt == "json" else yaml.safe_load(response.text)
    assert doc["project_version"] and doc["created"] and doc["motion"]["ca"] == 0.02
    http.post("/api/presets/paper/load")
    media = "application/json" if fmt == "json" else "application/yaml"
    imported = http.post("/api/import", content=response.content, headers={"content-type": media})
    assert imported.status_code == 200, imported.text
    after = imported.json()
    assert (after["motion"], after["gait"]) == (before["motion"], before["gait"])
    http.post("/api/presets/paper/load")


def test_c_header_export(http):
    response = http.get("/api/export", params={"format": "c"})
    assert response.status_code == 200
    assert (
        "#define ARTRO_SWING_V" in response.text
        and "artro_params.h" in response.headers["content-disposition"]
    )
    assert http.get("/api/export", params={"format": "pdf"}).status_code == 422


BAD_IMPORTS = [
    (b"{", "application/json", 422),
    (b"[1, 2]", "application/json", 422),
    (b'{"gait": {"swing": {"v": NaN}}}', "application/json", 422),
    (b'{"gait": {"swing": {"speed": 2}}}', "application/json", 422),
    (b'{"motion": {"a_p": 5}}', "application/json", 422),
    (b"\xff\xfe\x00garbage", "application/json", 422),
    (b"\xff\xfe\x00garbage", "application/octet-stream", 415),
    (b'{"motion": {"a_p": 0.1}}', "text/plain", 415),
    (b"a: &a [1]\nb: *a\n", "application/yaml", 422),
    (b'{"name": "' + b"x" * 70_000 + b'"}', "application/json", 413),
]


@pytest.mark.parametrize(("body", "media", "status"), BAD_IMPORTS)
def test_bad_imports_are_refused_and_change_nothing(http, body, media, status):
    before = http.get("/api/params").json()
    response = http.post("/api/import", content=body, headers={"content-type": media})
    assert response.status_code == status, response.text
    assert response.json()["detail"]
    assert http.get("/api/params").json() == before
