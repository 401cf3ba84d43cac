"""The gait's parameters: the motion vector and every constant of eqs (12)–(39), paper defaults.

The one parameter schema of the project (docs/DESIGN.md §4): validation, sliders and exports are
generated from its field metadata (`describe_fields`); signs of the motion vector: §3.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field, fields
from typing import Any

from gait.feedback_params import (
    LAWS,
    AttitudeParams,
    CopParams,
    DampingParams,
    TiltParams,
    TimingParams,
    YawRateParams,
)
from gait.motion_params import LateralParams, RampParams, SteerParams
from gait.pfs_params import PfsParams
from gait.phase_params import (
    BalanceParams,
    LegParams,
    LoadParams,
    ShiftParams,
    ShortParams,
    SwingParams,
)
from gait.schema_fields import GROUP_KEYS
from gait.schema_fields import check_ranges as _check_ranges
from gait.schema_fields import tunable as _param

PHASE_GROUPS = ("shift", "short", "swing", "load", "balance")
#: The gait engines a parameter set can name (docs/DESIGN.md §4): Behnke's walking phases of
#: seed 000 (eqs 10–45) and seed 004's own oscillator gait (eqs 1–3, 10–11, `gait.pfs`).
ENGINES = ("behnke", "pfs")


@dataclass(frozen=True)
class Motion:
    """The motion vector a_Robot = (a_r, a_p, a_y) and the curve amount CA (seed 004, eqs 10–11).

    a_r, a_p, a_y in rad, CA unitless; signs as in docs/DESIGN.md §3. Construction checks every
    range: ValueError names the field and what is allowed.
    """

    a_r: float = _param(
        0.0, -0.3, 0.3, step=0.005, unit="rad", eq="(13)",
        doc="lateral walking amplitude; > 0 steps to the robot's right",
    )  # fmt: skip
    a_p: float = _param(
        0.0, -0.3, 0.3, step=0.005, unit="rad", eq="(28)",
        doc="sagittal walking amplitude; > 0 walks forward",
    )  # fmt: skip
    a_y: float = _param(
        0.0, -0.6, 0.6, step=0.01, unit="rad", eq="(29)",
        doc="rotation amplitude; > 0 turns clockwise (seen from above)",
    )  # fmt: skip
    ca: float = _param(
        0.0, -0.5, 0.5, step=0.001, unit="1", eq="seed 004 (10)-(11)",
        doc="curve amount; > 0 makes left steps longer and turns clockwise",
    )  # fmt: skip

    def __post_init__(self) -> None:
        _check_ranges(self)


@dataclass(frozen=True)
class ClockParams:
    """The walking clock: phi_Trunk advances by 2*pi*f*dt (the paper gives no f)."""

    freq_hz: float = _param(
        1.0, 0.2, 3.0, step=0.01, unit="Hz", eq="(10)-(11)",
        doc="gait cycle frequency (one left and one right step per cycle)",
    )  # fmt: skip

    def __post_init__(self) -> None:
        _check_ranges(self)


@dataclass(frozen=True)
class GaitParams:
    """Every walking-phase constant, grouped by phase, with the paper's values as defaults.

    Frozen; each group checks its ranges on construction (ValueError naming `group.field` and the
    allowed range). As a dict: `{"engine": name, group: {field: value}}`, groups as the
    attributes below.

    `engine` names the gait engine that turns these into joint angles (one of ENGINES): `behnke`
    uses the walking-phase groups of seed 000, `pfs` the `pfs` group; `clock`, `steer`, `ramp` and
    the feedback groups (`FEEDBACK_GROUPS`: the laws, all off by default) serve both
    (`engine_groups`).
    """

    engine: str = field(
        default="behnke",
        metadata={
            "unit": "enum",
            "choices": ENGINES,
            "eq": "",
            "doc": "gait engine: behnke (seed 000 eqs 10–45) or pfs (seed 004 eqs 1–3)",
        },
    )
    clock: ClockParams = field(default_factory=ClockParams)
    shift: ShiftParams = field(default_factory=ShiftParams)
    short: ShortParams = field(default_factory=ShortParams)
    swing: SwingParams = field(default_factory=SwingParams)
    load: LoadParams = field(default_factory=LoadParams)
    balance: BalanceParams = field(default_factory=BalanceParams)
    leg: LegParams = field(default_factory=LegParams)
    lateral: LateralParams = field(default_factory=LateralParams)
    steer: SteerParams = field(default_factory=SteerParams)
    ramp: RampParams = field(default_factory=RampParams)
    pfs: PfsParams = field(default_factory=PfsParams)
    attitude: AttitudeParams = field(default_factory=AttitudeParams)
    tilt: TiltParams = field(default_factory=TiltParams)
    yaw_rate: YawRateParams = field(default_factory=YawRateParams)
    damping: DampingParams = field(default_factory=DampingParams)
    cop: CopParams = field(default_factory=CopParams)
    timing: TimingParams = field(default_factory=TimingParams)

    def __post_init__(self) -> None:
        if self.engine not in ENGINES:
            raise ValueError(f"engine {self.engine!r} is unknown; allowed: {', '.join(ENGINES)}")

    def to_dict(self) -> dict[str, Any]:
        """`{"engine": "behnke", group: {field: value}}` with every field, e.g.
        {'engine': 'behnke', 'swing': {'v': 2.0, ...}, ...}."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> GaitParams:
        """Build from a (possibly partial) nested dict; unknown groups or fields are errors."""
        return merge(cls(), data)

    def flat(self) -> dict[str, str | float | bool]:
        """{'engine': 'behnke', 'clock.freq_hz': 1.0, 'swing.v': 2.0, ...}: the form optimisers and
        diffs use (dotted names for the group fields)."""
        groups = {g: getattr(self, g) for g in GROUP_NAMES}
        return {"engine": self.engine} | {
            f"{g}.{f.name}": getattr(group, f.name) for g, group in groups.items()
            for f in fields(group)
        }  # fmt: skip


#: each group's dataclass, in schema order (the fields of GaitParams but `engine`)
_GROUP_CLASSES: dict[str, type] = {
    f.name: f.default_factory  # type: ignore[misc]
    for f in fields(GaitParams) if f.name != "engine"
}  # fmt: skip
GROUP_KEYS.update({cls.__name__: key for key, cls in _GROUP_CLASSES.items()})  # for errors
#: Every parameter group, in schema order (the fields of GaitParams but `engine`).
GROUP_NAMES: tuple[str, ...] = tuple(_GROUP_CLASSES)
#: the balance feedback on top of either engine (docs/DESIGN.md §15): the laws, each with its
#: switch, in the firmware's order (`gait.feedback_params.LAWS`), and the attitude estimate
LAW_GROUPS: tuple[str, ...] = tuple(law.group for law in LAWS)
if tuple(g for g in GROUP_NAMES if g in LAW_GROUPS) != LAW_GROUPS or any(
    _GROUP_CLASSES[law.group] is not law.params for law in LAWS
):
    raise RuntimeError("GaitParams must hold each law of LAWS as its group, in LAWS' order")
FEEDBACK_GROUPS = ("attitude", *LAW_GROUPS)
#: Groups every engine uses.
COMMON_GROUPS = ("clock", "steer", "ramp", *FEEDBACK_GROUPS)
_ENGINE_ONLY = {"behnke": (*PHASE_GROUPS, "leg", "lateral"), "pfs": ("pfs",)}


def engine_groups(engine: str) -> tuple[str, ...]:
    """The parameter groups `engine` reads, in schema order: what a UI shows for it."""
    if engine not in ENGINES:
        raise ValueError(f"engine {engine!r} is unknown; allowed: {', '.join(ENGINES)}")
    used = set(COMMON_GROUPS) | set(_ENGINE_ONLY[engine])
    return tuple(g for g in GROUP_NAMES if g in used)


def merge(params: GaitParams, patch: Mapping[str, Any]) -> GaitParams:
    """Return `params` with the fields named in a nested partial dict replaced (validated).

    `patch` is `{group: {field: value}}` with any subset of groups and fields; ValueError
    for an unknown group or field, a wrong type or a value out of range.
    """
    if not isinstance(patch, Mapping):
        raise ValueError(f"gait parameters must be an object of groups {sorted(_GROUP_CLASSES)}")
    groups: dict[str, Any] = {}
    for group_name, values in patch.items():
        if group_name == "engine":
            if not isinstance(values, str) or values not in ENGINES:
                raise ValueError(f"engine {values!r} is unknown; allowed: {', '.join(ENGINES)}")
            groups["engine"] = values
            continue
        if group_name not in _GROUP_CLASSES:
            raise ValueError(
                f"unknown parameter group {group_name!r}; allowed: 'engine' and groups "
                f"{sorted(_GROUP_CLASSES)}"
            )
        groups[group_name] = replace_checked(getattr(params, group_name), values, group_name)
    return dataclasses.replace(params, **groups)


def parse_settings(items: Iterable[str]) -> dict[str, Any]:
    """ "group.field=value" strings (true/false for switches), and "engine=NAME", as a nested
    patch for `merge`.

    ValueError if an item is not GROUP.FIELD=VALUE or its value is no number or true/false; names
    and ranges are checked later, by `merge`.
    """
    patch: dict[str, Any] = {}
    for item in items:
        key, sep, raw = item.partition("=")
        if key.strip() == "engine" and sep:
            patch["engine"] = raw.strip()
            continue
        group, dot, field = key.partition(".")
        if not sep or not dot:
            raise ValueError(f"a setting is GROUP.FIELD=VALUE, e.g. swing.v=3.0; got {item!r}")
        switch = {"true": True, "false": False}.get(raw.strip().lower())
        if switch is None:
            try:
                value: Any = float(raw)
            except ValueError:
                raise ValueError(f"{key}: {raw!r} is not a number or true/false") from None
        else:
            value = switch
        patch.setdefault(group, {})[field] = value
    return patch


def replace_checked(obj: Any, values: Mapping[str, Any], where: str) -> Any:
    """dataclasses.replace with type checks and a clear error for unknown names.

    Args:
        obj: a parameter group (or `Motion`) instance.
        values: field name -> new value (bool for switches, int or float otherwise).
        where: the group's user-facing name for messages, e.g. "swing" or "motion".

    Returns:
        A new instance, range-checked. ValueError names the field and what is allowed.
    """
    if not isinstance(values, Mapping):
        raise ValueError(f"{where} must be an object, got {type(values).__name__}")
    known = {f.name: f for f in fields(obj)}
    clean: dict[str, Any] = {}
    for name, value in values.items():
        if name not in known:
            raise ValueError(f"unknown field {where}.{name}; allowed: {sorted(known)}")
        is_bool = known[name].metadata.get("unit") == "bool"
        if is_bool:
            if not isinstance(value, bool):
                raise ValueError(f"{where}.{name} must be true or false, got {value!r}")
        elif isinstance(value, bool) or not isinstance(value, int | float):
            raise ValueError(f"{where}.{name} must be a number, got {value!r}")
        clean[name] = value if is_bool else float(value)
    return dataclasses.replace(obj, **clean)


def describe_fields(cls: type) -> Iterator[tuple[str, Any, Mapping[str, Any]]]:
    """(name, default, metadata) for each field of a parameter group: what UIs are built from.

    metadata: min, max, step, unit, eq, doc for numbers; unit "bool", eq "", doc for switches.
    """
    defaults = cls()
    for f in fields(cls):
        yield f.name, getattr(defaults, f.name), f.metadata


def group_class(name: str) -> type:
    """The dataclass of parameter group `name` ("clock", "shift", ..., "leg"); KeyError if none."""
    return _GROUP_CLASSES[name]
