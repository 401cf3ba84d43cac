"""Export/import of parameter sets (app.params.formats): round trips, provenance, bad uploads."""

from __future__ import annotations

import json

import pytest
import yaml

from app.params.document import ParameterSet, project_version
from app.params.formats import FORMATS, MAX_IMPORT_BYTES, ImportTooLarge, export_text, parse_import
from app.params.strict_text import ParameterImportError, load_json_strict
from gait import GaitParams, Motion


def tuned() -> ParameterSet:
    gait = GaitParams.from_dict(
        {"swing": {"v": 2.35, "o": -0.17}, "leg": {"paper_signs": False, "eta_min": 0.9}}
    )
    return ParameterSet(name="tuned walk", motion=Motion(a_p=0.07, a_y=-0.1, ca=0.013), gait=gait)


@pytest.mark.parametrize("fmt", ["json", "yaml"])
def test_export_reimports_to_same_parameters(fmt: str) -> None:
    text, media_type, filename = export_text(tuned(), fmt)
    assert media_type == {"json": "application/json", "yaml": "application/yaml"}[fmt]
    assert filename == f"tuned_walk.{fmt}"
    back = parse_import(text.encode(), content_type=media_type)
    assert back.gait == tuned().gait and back.motion == tuned().motion
    assert back.name == "tuned walk"
    # The format is also recognised without a content type, from the name or the text itself.
    assert parse_import(text.encode(), filename=filename) == back
    assert parse_import(text.encode()) == back


@pytest.mark.parametrize("fmt", FORMATS)
def test_every_export_carries_provenance(fmt: str) -> None:
    text, _, _ = export_text(tuned(), fmt)
    assert "tuned walk" in text
    assert project_version() in text
    if fmt == "json":
        document = json.loads(text)
        assert list(document) == [
            "schema_version",
            "name",
            "robot",
            "created",
            "project_version",
            "motion",
            "gait",
        ]
        assert document["created"]
    if fmt == "yaml":
        assert isinstance(yaml.safe_load(text)["created"], str)


def test_c_export_is_the_header() -> None:
    text, media_type, filename = export_text(ParameterSet(), "C")
    assert (media_type, filename) == ("text/x-c", "artro_params.h")
    assert "#define ARTRO_SELECT_CHANGE_TICKS 4900u" in text
    assert "#define ARTRO_SWING_V 2.0f" in text and "eq (23)" in text


def test_unknown_format_names_the_allowed_ones() -> None:
    with pytest.raises(ValueError, match="unknown export format 'xml'; allowed: json, yaml, c"):
        export_text(ParameterSet(), "xml")


def test_partial_yaml_takes_paper_defaults() -> None:
    raw = b"# hand written\nmotion:\n  a_p: 0.05\ngait:\n  swing: {v: 2.5}\ncreated: 2024-05-01\n"
    pset = parse_import(raw, filename="mine.yml")
    assert pset.motion == Motion(a_p=0.05)
    assert pset.gait.swing.v == 2.5 and pset.gait.short == GaitParams().short
    assert pset.created == "2024-05-01"  # an unquoted date stays a string


BOMB = b"""a: &a ["x", "x", "x", "x", "x", "x", "x", "x", "x"]
b: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a]
c: &c [*b, *b, *b, *b, *b, *b, *b, *b, *b]
d: &d [*c, *c, *c, *c, *c, *c, *c, *c, *c]
e: &e [*d, *d, *d, *d, *d, *d, *d, *d, *d]
f: &f [*e, *e, *e, *e, *e, *e, *e, *e, *e]
g: &g [*f, *f, *f, *f, *f, *f, *f, *f, *f]
"""


@pytest.mark.parametrize(
    ("raw", "message"),
    [
        (b"{" + b" " * MAX_IMPORT_BYTES + b"}", "at most 65536 bytes"),
        (bytes(range(256)) * 4, "not UTF-8 text"),
        (b"\x00\x01\x02garbage", "NUL bytes"),
        (b"", "empty"),
        (b"{", "malformed JSON at line 1, column 2"),
        (b'{"motion": {"a_p": 0.1,}}', "malformed JSON at line 1, column 24"),
        (b"[1,2]", "must be a JSON object"),
        (b"just text", "must be a YAML object"),
        (b"- 1\n- 2\n", "must be a YAML object"),
        (b"motion: [1, 2\n", "malformed YAML at line 2"),
        (b'{"motion": {"a_p": NaN}}', "NaN is not allowed"),
        (b'{"motion": {"a_p": -Infinity}}', "-Infinity is not allowed"),
        (b'{"motion": {"a_p": 1e999}}', "motion.a_p = inf: every number must be finite"),
        (b"motion:\n  a_p: .nan\n", "motion.a_p = nan: every number must be finite"),
        (b"motion:\n  a_p: -.inf\n", "every number must be finite"),
        (b'{"motion": {"a_p": 0.1, "a_p": 0.2}}', "duplicate key 'a_p'"),
        (b"motion: {a_p: 0.1}\nmotion: {a_p: 0.2}\n", "duplicate key 'motion'"),
        (b'{"motion": {"speed": 1}}', "unknown field motion.speed; allowed:"),
        (b'{"gait": {"swing": {"v": 99}}}', "swing.v = 99.0 is out of range"),
        (b'{"colour": "red"}', "unknown keys ['colour']"),
        (b'{"motion": {"a_p": "fast"}}', "motion.a_p must be a number"),
        (b'{"schema_version": 3}', "schema_version 3 is not supported; this is 2"),
        (b'{"schema_version": true}', "schema_version True is not supported"),
        (b'{"schema_version": 1, "gait": {"engine": "pfs"}}', "schema_version 1 has no"),
        (b'{"created": 5}', "created must be a string"),
        (BOMB, "anchors and aliases"),
        (b"motion: !!python/object:os.system {}\n", "malformed YAML at line 1"),
        (b"name: !!binary aGVsbG8=\n", "name: a bytes value is not allowed"),
        (b"? [1, 2]\n: x\n", "malformed YAML"),
        (b"[" * 5000 + b"]" * 5000, "nested too deeply"),
        (b"a: " + b"[" * 20 + b"]" * 20, "nested too deeply"),
        (b"a: " + b"[" * 5000 + b"]" * 5000, "nested too deeply"),
        # issue 56 item 18: Python's advice (sys.set_int_max_str_digits), a ValueError for YAML
        (b'{"motion": {"a_p": ' + b"1" * 5000 + b"}}", "a whole number of 5000 digits; a"),
        (b"motion:\n  a_p: " + b"1" * 5000 + b"\n", "a whole number of 5000 digits; a"),
    ],
)
def test_bad_imports_are_rejected(raw: bytes, message: str) -> None:
    with pytest.raises(ParameterImportError) as info:
        parse_import(raw)
    assert isinstance(info.value, ValueError)
    assert message in str(info.value)
    assert "sys." not in str(info.value)  # no advice to a programmer


@pytest.mark.parametrize(
    "raw", [b"\xff\xfe\x00", '{"a": 1}'.encode("utf-16"), '{"a": 1}'.encode("utf-32")]
)
def test_a_json_body_in_another_encoding_is_named_so(raw: bytes) -> None:
    """A request body read as JSON (`load_json_strict`) is UTF-8: json.loads guessed UTF-16
    from the bytes and said "'utf-16-le' codec can't decode" (the hostile probe)."""
    with pytest.raises(ParameterImportError, match=r"not UTF-8 text .*JSON must be UTF-8"):
        load_json_strict(raw)
    assert load_json_strict(b'\xef\xbb\xbf{"a": 1}') == {"a": 1}  # a UTF-8 BOM is read past


def test_json_under_a_yaml_content_type_still_parses() -> None:
    raw = b'{"motion": {"a_p": 0.1}}'  # JSON is YAML
    assert parse_import(raw, content_type="text/yaml; charset=utf-8").motion == Motion(a_p=0.1)
    assert parse_import(raw, filename="x.YAML").motion == Motion(a_p=0.1)


def test_too_large_is_its_own_error() -> None:
    with pytest.raises(ImportTooLarge):
        parse_import(b" " * (MAX_IMPORT_BYTES + 1))
    text, _, _ = export_text(ParameterSet(), "json")
    padded = text.encode() + b" " * (MAX_IMPORT_BYTES - len(text.encode()))
    assert parse_import(padded) == parse_import(text.encode())
