"""Whether a description's joint ranges hold the gait's poses: the knees' bend to the shortest
leg (eqs 3–7) and the poses of seed 000's table motions (eqs 2–45), for the paper's constants and
a built-in preset's, read here without `app.params` (docs/DESIGN.md §7)."""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Mapping, Sequence

import numpy as np

from app.assets import builtin_presets_dir
from app.robots.description_parts import Geometry, Joint
from gait import JOINT_NAMES, GaitParams, LegGeometry, Motion, joint_angles_with_flags
from gait.leg_interface import knee_triangle

#: the motions whose poses every joint's range must hold: seed 000's table, both ways
REACH_CASES = (
    Motion(),
    *(Motion(**{axis: sign * value}) for axis, value in (("a_p", 0.07), ("a_r", 0.1), ("a_y", 0.2))
      for sign in (1.0, -1.0)),
)  # fmt: skip
REACH_PHASES = 64


@functools.cache
def preset_gait(name: str) -> GaitParams:
    """The gait constants of the built-in preset `name` (models/presets/NAME.json), read here:
    the robots' checks need no parameter-set documents (`app.params`)."""
    doc = json.loads((builtin_presets_dir() / f"{name}.json").read_text(encoding="utf-8"))
    return GaitParams.from_dict(doc["gait"])


def check_reach(
    joints: Mapping[str, Joint], geometry: Geometry, gaits: Sequence[tuple[str, GaitParams]]
) -> None:
    """Every joint's range holds the poses of the table motions in each named gait it is checked
    for (`RobotDescription.walked_gaits`, this robot's legs): a narrower range stops the walk at
    its limit. Raises ValueError naming the joint, its range and the reach it lacks."""
    legs = LegGeometry(upper_m=geometry.thigh_m, lower_m=geometry.shank_m)
    phases = np.linspace(-np.pi, np.pi, REACH_PHASES, endpoint=False)
    for gait_name, gait in gaits:
        poses = np.concatenate(
            [joint_angles_with_flags(gait, m, phases, legs).values for m in REACH_CASES]
        )
        for i, name in enumerate(JOINT_NAMES):
            lo, hi = joints[name].range_rad
            need_lo, need_hi = float(poses[:, i].min()), float(poses[:, i].max())
            if need_lo < lo - 1e-6 or need_hi > hi + 1e-6:
                raise ValueError(
                    f"joints.{name}.range_rad: {lo:.4f}..{hi:.4f} rad does not hold the "
                    f"gait's reach of {need_lo:.4f}..{need_hi:.4f} rad ({gait_name} walking "
                    f"forward, backward, sideways and turning at seed 000's table speeds)"
                )


def check_knee_reach(joints: Mapping[str, Joint], geometry: Geometry, eta_min: float) -> None:
    """The knees bend to the gait's shortest leg, knee = α1 − π at η_min (eqs 3–7), and
    straighten (η = 1, knee 0). Raises ValueError naming the knee and the reach it needs."""
    legs = LegGeometry(upper_m=geometry.thigh_m, lower_m=geometry.shank_m)
    alpha1, _, _ = knee_triangle(eta_min, legs)
    knee_rad = float(alpha1) - math.pi
    for side in ("l", "r"):
        lo, hi = joints[f"{side}_knee"].range_rad
        if knee_rad < lo - 1e-9 or hi < 0.0:
            raise ValueError(
                f"joints.{side}_knee.range_rad: {lo:.4f}..{hi:.4f} rad must reach from "
                f"{knee_rad:.4f} rad (the gait's shortest leg, eta_min = {eta_min:g}) to 0 "
                f"(a straight leg)"
            )
