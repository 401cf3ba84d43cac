"""Pydantic models for the HTTP API, generated from the one parameter schema in `gait.params`.

Nothing here lists a parameter by hand (docs/DESIGN.md §4): see `ParamsBody`, `ParamsPatchBody`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Annotated, Any, Literal, Union

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, TypeAdapter, create_model

from app.params.document import V2_GROUPS
from gait.feedback_params import LAWS
from gait.params import (
    ENGINES,
    GROUP_NAMES,
    GaitParams,
    Motion,
    describe_fields,
    engine_groups,
    group_class,
)

#: gait.params.ENGINES; tests/params/test_schema_engine.py checks
EngineName = Literal["behnke", "pfs"]
ENGINE_DOC: str = GaitParams.__dataclass_fields__["engine"].metadata["doc"]

#: Folder titles for user interfaces, in display order.
GROUP_TITLES = {
    "clock": "Clock",
    "shift": "Shifting",
    "short": "Shortening",
    "swing": "Swinging",
    "load": "Loading",
    "balance": "Balancing",
    "leg": "Leg",
    "lateral": "Lateral support",
    "steer": "Steering (CA)",
    "ramp": "Motion ramp",
    "pfs": "PFS oscillators",
    "attitude": "Attitude estimate",
    **{law.group: law.title for law in LAWS},  # each law's own (gait.feedback_params)
}

# forbid unknown fields, NaN and inf, and take no strings for numbers
STRICT = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True)


def _field_args(meta: Mapping[str, Any]) -> dict[str, Any]:
    if meta.get("unit") == "bool":
        return {"description": meta["doc"]}
    return {
        "ge": meta["min"],
        "le": meta["max"],
        "description": f"{meta['doc']} [{meta['unit']}] eq {meta['eq']}",
        "json_schema_extra": {"step": meta["step"], "unit": meta["unit"]},
    }


def _model_for(cls: type, name: str, *, partial: bool, defaults: bool = False) -> type[BaseModel]:
    """A model of one parameter group whose fields carry the range, unit and description of the
    dataclass metadata; every field required, or (`partial`) every field optional (null allowed),
    or (`defaults`) every field optional with the paper's value."""
    definitions: dict[str, Any] = {}
    for field_name, default, meta in describe_fields(cls):
        kind = bool if meta.get("unit") == "bool" else float
        if defaults:
            definitions[field_name] = (kind, Field(default, **_field_args(meta)))
        elif partial:
            definitions[field_name] = (kind | None, Field(None, **_field_args(meta)))
        else:
            definitions[field_name] = (kind, Field(..., **_field_args(meta)))  # required
    return create_model(name, __config__=STRICT, **definitions)


if TYPE_CHECKING:  # mypy cannot follow create_model: to it, each model made here is a BaseModel
    MotionModel = BaseModel
    MotionPatch = BaseModel
    MotionImport = BaseModel
    GaitModel = BaseModel
    GaitPatch = BaseModel
    GaitImport = BaseModel
    GaitImportV1 = BaseModel
else:
    MotionModel = _model_for(Motion, "Motion", partial=False)
    MotionPatch = _model_for(Motion, "MotionPatch", partial=True)

    _groups_full: dict[str, Any] = {
        g: (_model_for(group_class(g), f"{g.title()}Params", partial=False), ...)
        for g in GROUP_NAMES
    }
    _groups_patch: dict[str, Any] = {
        g: (_model_for(group_class(g), f"{g.title()}Patch", partial=True) | None, None)
        for g in GROUP_NAMES
    }
    GaitModel = create_model(
        "Gait",
        __config__=STRICT,
        engine=(EngineName, Field("behnke", description=ENGINE_DOC)),
        **_groups_full,
    )
    GaitPatch = create_model(
        "GaitPatch",
        __config__=STRICT,
        engine=(EngineName | None, Field(None, description=ENGINE_DOC)),
        **_groups_patch,
    )

    _groups_import: dict[str, Any] = {
        g: (_model_for(group_class(g), f"{g.title()}Import", partial=True, defaults=True), None)
        for g in GROUP_NAMES
    }
    MotionImport = _model_for(Motion, "MotionImport", partial=True, defaults=True)
    GaitImport = create_model(
        "GaitImport",
        __config__=STRICT,
        engine=(EngineName, Field("behnke", description=ENGINE_DOC)),
        **_groups_import,
    )

    GaitImportV1 = create_model(
        "GaitImportV1",
        __config__=STRICT,
        **{g: spec for g, spec in _groups_import.items() if g not in V2_GROUPS},
    )


MAX_VERSION = 2**53  # JSON-safe integer


def _whole_float_to_int(value: Any) -> Any:
    """JSON has one number type: 12.0 is the integer 12 (JSON Schema agrees); 12.5 stays wrong."""
    if isinstance(value, float) and value.is_integer() and abs(value) <= MAX_VERSION:
        return int(value)
    return value


Version = Annotated[int, Field(ge=1, le=MAX_VERSION), BeforeValidator(_whole_float_to_int)]
BaseVersion = Field(
    None,
    description="the version this change is based on (what GET returned); if another change "
    "came first, 409 with the current version and nothing changed",
)
NAME_FIELD = Field(None, min_length=1, max_length=64, description="the parameter set's name")
ROBOT_FIELD = Field(
    None,
    pattern=r"^[a-z][a-z0-9_-]{0,39}$",
    description="the robot the set was tuned for (default artro); informative: a set loaded on "
    "another robot is loaded with a warning",
)


class ParamsBody(BaseModel):
    """A full parameter set: the motion vector with CA, and every gait constant.

    The motion and every gait field are required (a PUT is a whole parameter set); unknown fields,
    NaN, inf and strings for numbers are refused, and every range of `gait.params` applies. What
    `GET /api/params` returns and an exported JSON file are both accepted as they are.
    """

    model_config = STRICT
    version: Version | None = BaseVersion
    name: str | None = NAME_FIELD
    robot: str | None = ROBOT_FIELD
    schema_version: Literal[1, 2] = Field(2, description="of an exported file")
    created: str | None = Field(None, max_length=64, description="of an exported file; ignored")
    project_version: str | None = Field(
        None, max_length=64, description="of an exported file; ignored"
    )
    motion: MotionModel
    gait: GaitModel


class ParamsPatchBody(BaseModel):
    """Any subset of the parameters; what is left out stays as it is (checks as `ParamsBody`)."""

    model_config = STRICT
    version: Version | None = BaseVersion
    name: str | None = NAME_FIELD
    motion: MotionPatch | None = None
    gait: GaitPatch | None = None

    def as_patch(self) -> dict[str, Any]:
        """Nested dict of only the parameters the client sent (not the version)."""
        return self.model_dump(exclude_none=True, exclude_unset=True, exclude={"version"})


def schema_description() -> list[dict[str, Any]]:
    """Every group and field with label, default, range, step, unit, equation and description:
    what user interfaces build their controls from.

    Returns `[{"group": "motion", "title": "Motion", "engines": ["behnke", "pfs"], "fields":
    [{"name", "default", "min", "max", "step", "unit", "eq", "doc"}, ...]}, ...]`: motion first,
    then the gait groups in order (switches have unit "bool" and no min, max or step); `engines`
    lists the engines that use the group (`gait.params.engine_groups`), so a UI can show the
    active engine's groups only. The engine itself is `GaitModel.engine`.
    """
    groups = [("motion", "Motion", Motion)] + [
        (g, GROUP_TITLES[g], group_class(g)) for g in GROUP_NAMES
    ]
    out = []
    for key, title, cls in groups:
        entries = []
        for name, default, meta in describe_fields(cls):
            entry = {"name": name, "default": default, **dict(meta)}
            entries.append(entry)
        engines = [e for e in ENGINES if key == "motion" or key in engine_groups(e)]
        out.append({"group": key, "title": title, "engines": engines, "fields": entries})
    return out


class _ImportFields(BaseModel):
    model_config = STRICT
    version: Annotated[int, BeforeValidator(_whole_float_to_int)] | None = Field(
        None, description="ignored (a document from GET /api/params)"
    )
    name: str | None = None
    robot: str | None = ROBOT_FIELD
    created: str | None = None
    project_version: str | None = None
    # None when left out, though a body's null is refused: mypy has no type for that
    motion: MotionImport = None  # type: ignore[assignment]


class ImportBody(_ImportFields):
    """An imported parameter set (`POST /api/import`, JSON or YAML): an exported file or what
    `GET /api/params` returns; groups and fields left out take the paper's values."""

    schema_version: Literal[2] | None = None
    # None when left out, though a body's null is refused: mypy has no type for that
    gait: GaitImport = None  # type: ignore[assignment]


class ImportBodyV1(_ImportFields):
    """A parameter set of schema version 1 (before the engine and the steer, ramp and pfs
    groups; app/params/document.py)."""

    schema_version: Literal[1]
    # None when left out, though a body's null is refused: mypy has no type for that
    gait: GaitImportV1 = None  # type: ignore[assignment]


def inline_schema(*models: type[BaseModel]) -> dict[str, Any]:
    """The JSON schema of one of `models`, definitions inlined (for an OpenAPI `openapi_extra`)."""
    union: Any = Union[models]  # noqa: UP007 (a runtime tuple: a type known only when it runs)
    schema = TypeAdapter(union).json_schema()
    defs = schema.pop("$defs", {})

    def resolve(node: Any) -> Any:
        if isinstance(node, dict):
            ref = node.get("$ref", "")
            if ref.startswith("#/$defs/"):
                return resolve(defs[ref.removeprefix("#/$defs/")])
            return {k: resolve(v) for k, v in node.items()}
        if isinstance(node, list):
            return [resolve(v) for v in node]
        return node

    return resolve(schema)
