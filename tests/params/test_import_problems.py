"""An import with several wrong fields names every one of them, with its path (issue 9); a
parameter file on the command line is read by the same rules."""

import json

import pytest

from app.params.formats import export_text, load_parameter_set, parse_import
from app.params.presets import builtin_presets
from app.params.strict_text import ParameterImportError

FOUR_WRONG = {
    "motion": {"a_p": 2},
    "gait": {"swing": {"v": 99}, "short": {"v": "fast"}, "load": {"v": -1}},
}


def test_parse_import_lists_every_wrong_field():
    with pytest.raises(ParameterImportError) as caught:
        parse_import(json.dumps(FOUR_WRONG).encode(), "application/json")
    locs = [tuple(p["loc"]) for p in caught.value.problems]
    assert sorted(locs) == sorted(
        [("motion", "a_p"), ("gait", "swing", "v"), ("gait", "short", "v"), ("gait", "load", "v")]
    )
    assert "4 problems" in str(caught.value)
    swing = next(p for p in caught.value.problems if p["loc"] == ["gait", "swing", "v"])
    assert "allowed: 1.5 to 6.0" in swing["msg"]


def test_one_wrong_field_keeps_the_one_line_message():
    with pytest.raises(ParameterImportError, match=r"swing\.v = 99\.0 is out of range"):
        parse_import(json.dumps({"gait": {"swing": {"v": 99}}}).encode(), "application/json")


def test_the_import_route_returns_every_problem_and_changes_nothing(http):
    before = http.get("/api/params").json()
    response = http.post(
        "/api/import",
        content=json.dumps(FOUR_WRONG | {"colour": "red"}).encode(),
        headers={"Content-Type": "application/json"},
    )
    assert response.status_code == 422
    detail = response.json()["detail"]
    assert len(detail) == 5 and ["colour"] in [p["loc"] for p in detail]
    assert http.get("/api/params").json() == before


def test_a_parameter_file_is_read_by_the_imports_rules(tmp_path):
    """`--params FILE` of every command: the YAML `artro export` writes reads back, and a file
    with a key twice or in UTF-16 is refused naming the file, as an upload would be."""
    robust = builtin_presets()["robust"]
    text, _media, _name = export_text(robust, "yaml")
    (tmp_path / "r.yaml").write_text(text, encoding="utf-8")
    assert load_parameter_set(tmp_path / "r.yaml").gait == robust.gait
    twice = tmp_path / "twice.json"
    twice.write_text('{"gait": {"cop": {"kp": 1}}, "gait": {}}', encoding="utf-8")
    with pytest.raises(ValueError, match=r"twice\.json: duplicate key 'gait'"):
        load_parameter_set(twice)
    wide = tmp_path / "wide.json"
    wide.write_text('{"name": "x"}', encoding="utf-16")
    with pytest.raises(ValueError, match=r"wide\.json: the file is not UTF-8 text"):
        load_parameter_set(wide)
    with pytest.raises(ValueError, match=r"gone\.json: cannot be read"):
        load_parameter_set(tmp_path / "gone.json")
