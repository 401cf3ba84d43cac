"""The firmware's parameter table `artro_schema.h`, generated from the one parameter schema
(`gait.params`): one-byte ids (motion, then the gait groups in schema order), ranges, switches, the
leg geometry and a schema hash the host checks (docs/DESIGN.md §5). The defaults in it
name the `ARTRO_<GROUP>_<FIELD>` values of `artro_params.h`, i.e. the exported parameter set."""

from __future__ import annotations

import dataclasses
import math
import zlib
from collections.abc import Sequence
from dataclasses import dataclass

from gait.leg_interface import ARTRO_LEG, LegGeometry
from gait.params import (
    FEEDBACK_GROUPS,
    GaitParams,
    Motion,
    describe_fields,
    engine_groups,
    group_class,
    merge,
)
from hardware.firmware.header import c_float, c_identifier

SCHEMA_HEADER_NAME = "artro_schema.h"
MAX_PARAMS = 250  # ids are one byte; 0xFF is reserved
FIRMWARE_ENGINE = "behnke"  # the gait engine gait.c implements; artro_params.h must name it


@dataclass(frozen=True)
class ParamSpec:
    """One tunable value as the firmware sees it."""

    pid: int
    group: str  # "motion" or a gait group
    name: str
    is_switch: bool
    lo: float
    hi: float
    unit: str

    @property
    def dotted(self) -> str:
        return f"{self.group}.{self.name}"

    @property
    def c_name(self) -> str:
        """The value's define in artro_params.h, e.g. ARTRO_SWING_V."""
        return c_identifier(self.group, self.name)

    @property
    def c_pid(self) -> str:
        return c_identifier("PID", self.group, self.name)

    def check(self, value: float) -> None:
        """ValueError unless the firmware would accept `value` for this id."""
        if not math.isfinite(value):
            raise ValueError(f"{self.dotted} must be finite, got {value!r}")
        if self.is_switch and value not in (0.0, 1.0):
            raise ValueError(f"{self.dotted} is a switch: 0 or 1, got {value!r}")
        if not self.lo <= value <= self.hi:
            raise ValueError(f"{self.dotted} = {value!r} is out of range {self.lo}..{self.hi}")


def param_specs() -> tuple[ParamSpec, ...]:
    """Every tunable value with its id: motion (a_r, a_p, a_y, ca), then the gait groups of the
    engine the firmware runs, behnke (`gait.params.engine_groups`; no `pfs`), in schema order,
    then the feedback groups (attitude and the laws, docs/DESIGN.md §15): appended last, so the
    gait's ids are those of the open-loop firmware."""
    groups: list[tuple[str, type]] = [("motion", Motion)]
    groups += [
        (g, group_class(g)) for g in engine_groups(FIRMWARE_ENGINE) if g not in FEEDBACK_GROUPS
    ]
    groups += [(g, group_class(g)) for g in FEEDBACK_GROUPS]
    specs: list[ParamSpec] = []
    for group, cls in groups:
        for name, _default, meta in describe_fields(cls):
            switch = meta.get("unit") == "bool"
            lo, hi = (0.0, 1.0) if switch else (float(meta["min"]), float(meta["max"]))
            specs.append(ParamSpec(len(specs), group, name, switch, lo, hi, meta["unit"]))
    if len(specs) > MAX_PARAMS:
        raise ValueError(f"{len(specs)} parameters do not fit one-byte ids (max {MAX_PARAMS})")
    return tuple(specs)


def schema_hash(specs: tuple[ParamSpec, ...] | None = None) -> int:
    """CRC-32 of 'group.name:kind' lines in id order: equal on both ends of the link."""
    specs = param_specs() if specs is None else specs
    text = "\n".join(f"{s.dotted}:{'bool' if s.is_switch else 'float'}" for s in specs)
    return zlib.crc32(text.encode("ascii"))


def complete_document(doc: dict) -> dict:
    """A copy of a parameter-set document with every motion and gait field, the schema's
    defaults where `doc` leaves one out (e.g. a schema-version-1 document has no `steer`)."""
    motion = dataclasses.replace(Motion(), **doc.get("motion", {}))
    gait = merge(GaitParams(), doc.get("gait", {}))
    return {**doc, "motion": dataclasses.asdict(motion), "gait": gait.to_dict()}


def values_from_document(doc: dict) -> list[float]:
    """The id-ordered values of a parameter-set document (ParameterSet.to_dict(); fields left
    out take the schema's defaults)."""
    full = complete_document(doc)
    values = []
    for spec in param_specs():
        source = full["motion"] if spec.group == "motion" else full["gait"][spec.group]
        values.append(float(source[spec.name]))
    return values


#: x, y of each sole force sensor from the sole centre, m (corners fl, fr, bl, br: a quarter of
#: the foot's length and width in), for ArtRo (`RobotModel.fsr_positions_m`)
ARTRO_FSR_POSITIONS_M = ((0.03, 0.0175), (0.03, -0.0175), (-0.03, 0.0175), (-0.03, -0.0175))


def _ascii(unit: str) -> str:
    """A unit as C source may spell it (the header is ASCII): rad·s/m -> rad*s/m."""
    return unit.replace("·", "*").replace("°", "deg").replace("²", "^2")


def c_schema_header(
    geometry: LegGeometry = ARTRO_LEG,
    fsr_positions_m: Sequence[Sequence[float]] = ARTRO_FSR_POSITIONS_M,
) -> str:
    """The text of artro_schema.h (independent of the parameter set) for a robot's legs and
    sole force sensors."""
    specs = param_specs()
    out = [
        f"/* {SCHEMA_HEADER_NAME} -- parameter ids, ranges and switches of the ArtRo gait,",
        " * generated from the project's parameter schema; do not edit by hand.",
        " * The default values come from artro_params.h (ARTRO_<GROUP>_<FIELD>). */",
        "#ifndef ARTRO_SCHEMA_H",
        "#define ARTRO_SCHEMA_H",
        "",
        "#include <stdint.h>",
        "",
        f"#define ARTRO_PARAM_COUNT {len(specs)}",
        f"#define ARTRO_SCHEMA_HASH 0x{schema_hash(specs):08X}UL",
        "",
        "/* leg segments, hip -> knee -> ankle, eqs (3)-(6) */",
        f"#define ARTRO_GEOM_UPPER_LEG_M {c_float(geometry.upper_m)}",
        f"#define ARTRO_GEOM_LOWER_LEG_M {c_float(geometry.lower_m)}",
        "",
        "/* sole force sensors fl, fr, bl, br: x, y from the sole centre, m (laws.c) */",
        "#define ARTRO_FSR_POSITIONS_M { \\",
        *[f"    {{{c_float(x)}, {c_float(y)}}}, \\" for x, y in fsr_positions_m],
        "}",
        "",
        "enum artro_param_id {",
    ]
    out += [f"    {s.c_pid} = {s.pid}, /* {s.dotted} [{_ascii(s.unit)}] */" for s in specs]
    out += ["};", ""]
    out.append("/* defaults: the values of the exported parameter set, in id order */")
    out.append("#define ARTRO_PARAM_DEFAULTS { \\")
    out += [f"    (float)({s.c_name}), \\" for s in specs]
    out += ["}", ""]
    out.append("/* allowed range per id (switches: 0..1, and only 0 or 1) */")
    out.append("#define ARTRO_PARAM_MIN { \\")
    out += [f"    {c_float(s.lo)}, \\" for s in specs]
    out += ["}", "#define ARTRO_PARAM_MAX { \\"]
    out += [f"    {c_float(s.hi)}, \\" for s in specs]
    out += ["}", ""]
    switch_bits = sum(1 << s.pid for s in specs if s.is_switch)
    words = [(switch_bits >> (32 * i)) & 0xFFFFFFFF for i in range((len(specs) + 31) // 32)]
    out.append("/* bit i of word i/32: parameter i is a switch */")
    bits = ", ".join(f"0x{w:08X}UL" for w in words)
    out.append(f"#define ARTRO_PARAM_SWITCH_BITS {{ {bits} }}")
    out += ["", "#endif /* ARTRO_SCHEMA_H */", ""]
    return "\n".join(out)


def describe() -> list[dict]:
    """JSON-ready table of the ids (for PROTOCOL.md and host tools)."""
    return [
        {"id": s.pid, "name": s.dotted, "switch": s.is_switch, "min": s.lo, "max": s.hi}
        for s in param_specs()
    ]


__all__ = [
    "ARTRO_FSR_POSITIONS_M",
    "FIRMWARE_ENGINE",
    "SCHEMA_HEADER_NAME",
    "ParamSpec",
    "c_schema_header",
    "complete_document",
    "describe",
    "param_specs",
    "schema_hash",
    "values_from_document",
]
