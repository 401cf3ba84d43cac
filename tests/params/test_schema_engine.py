"""The engine field through the schema, the parameter-set document and the exports."""

import json

import pytest
import yaml
from pydantic import ValidationError

from app.params.document import ParameterSet
from app.params.formats import export_text, parse_import
from app.params.schema import EngineName, GaitModel, GaitPatch, schema_description
from gait import ENGINES, GaitParams, Motion


def test_the_api_knows_the_same_engines_as_the_gait() -> None:
    assert EngineName.__args__ == ENGINES  # type: ignore[attr-defined]
    full = GaitParams(engine="pfs").to_dict()
    assert GaitModel.model_validate(full).engine == "pfs"
    with pytest.raises(ValidationError, match="engine"):
        GaitModel.model_validate(full | {"engine": "zmp"})
    assert GaitPatch.model_validate({"engine": "pfs"}).model_dump(exclude_none=True) == {
        "engine": "pfs"
    }


def test_the_schema_says_which_groups_each_engine_shows() -> None:
    groups = {g["group"]: g["engines"] for g in schema_description()}
    assert groups["motion"] == groups["clock"] == groups["steer"] == ["behnke", "pfs"]
    assert groups["swing"] == ["behnke"] and groups["pfs"] == ["pfs"]


@pytest.mark.parametrize("fmt", ["json", "yaml"])
def test_a_pfs_parameter_set_exports_and_imports_with_its_engine(fmt: str) -> None:
    pset = ParameterSet(
        name="oscillators",
        motion=Motion(a_p=0.05, ca=0.1),
        gait=GaitParams.from_dict({"engine": "pfs", "pfs": {"knee_a": 0.2}}),
    )
    text, _media, filename = export_text(pset, fmt)
    doc = json.loads(text) if fmt == "json" else yaml.safe_load(text)
    assert doc["gait"]["engine"] == "pfs"
    back = parse_import(text.encode(), filename=filename)
    assert back.gait == pset.gait and back.motion == pset.motion


def test_the_c_header_names_the_engine() -> None:
    text, _media, _name = export_text(ParameterSet(gait=GaitParams(engine="pfs")), "c")
    assert "#define ARTRO_ENGINE_BEHNKE 0" in text and "#define ARTRO_ENGINE_PFS 1" in text
    assert "#define ARTRO_ENGINE ARTRO_ENGINE_PFS" in text
    assert "#define ARTRO_PFS_KNEE_A 0.15f" in text
    behnke, _media, _name = export_text(ParameterSet(), "c")
    assert "#define ARTRO_ENGINE ARTRO_ENGINE_BEHNKE" in behnke


def test_a_version_1_document_reads_as_the_behnke_gait_it_was() -> None:
    tuned = ParameterSet.from_dict(
        {"schema_version": 1, "motion": {"a_p": 0.07}, "gait": {"swing": {"v": 2.5}}}
    )
    assert tuned.gait.engine == "behnke" and tuned.gait.steer.yaw_per_ca == 0.0
    assert tuned.gait.swing.v == 2.5 and tuned.gait.ramp == GaitParams().ramp
    assert ParameterSet().to_dict()["schema_version"] == 2


def test_the_engine_switches_over_http_and_a_bad_one_changes_nothing(http) -> None:
    before = http.get("/api/params").json()
    assert before["gait"]["engine"] == "behnke" and "pfs" in before["gait"]
    bad = http.patch("/api/params", json={"gait": {"engine": "zmp", "pfs": {"knee_a": 0.2}}})
    assert bad.status_code == 422 and "behnke" in json.dumps(bad.json()["detail"])
    assert http.get("/api/params").json() == before
    done = http.patch("/api/params", json={"gait": {"engine": "pfs"}})
    assert done.status_code == 200 and done.json()["gait"]["engine"] == "pfs"
    assert http.get("/api/state").json()["running"]
