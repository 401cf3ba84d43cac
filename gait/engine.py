"""The gait engines behind one call (docs/DESIGN.md §4): `joint_angles` runs the engine that
`params.engine` names, behnke (seed 000 eqs 2–45) or pfs (seed 004 eqs 1–3, 10–11, `gait.pfs`), so
the frame loop, the batch evaluator and the exports all get the active one."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gait.leg_interface import ARTRO_LEG, JointAngles, LegGeometry, behnke_joint_angles_with_flags
from gait.params import GaitParams, Motion
from gait.pfs import pfs_joint_angles_with_flags
from gait.pfs import startup_gain as pfs_startup_gain


def startup_gain(params: GaitParams, time_s: ArrayLike) -> NDArray[np.float64]:
    """The start-up gain `time_s` after a start or reset, for `joint_angles(..., startup=)`:
    seed 004's Fig. 3 ramp for `pfs`; always 1 for `behnke`, whose start is the motion ramp."""
    if params.engine == "pfs":
        return pfs_startup_gain(params, time_s)
    return np.ones_like(np.asarray(time_s, dtype=float))


def joint_angles_with_flags(
    params: GaitParams,
    motion: Motion,
    phi_trunk: ArrayLike,
    geometry: LegGeometry = ARTRO_LEG,
    *,
    startup: ArrayLike = 1.0,
) -> JointAngles:
    """Joint angles (..., 12) in the joint order of docs/DESIGN.md §3, and per leg (..., 2)
    whether the leg-extension limit was clamped, from the engine `params.engine` names.

    `geometry` is the leg for the behnke engine's inverse kinematics; `startup` the start-up
    gain (`startup_gain`), which only the pfs engine has.
    """
    if params.engine == "pfs":
        return JointAngles(*pfs_joint_angles_with_flags(params, motion, phi_trunk, startup))
    return behnke_joint_angles_with_flags(params, motion, phi_trunk, geometry)


def joint_angles(
    params: GaitParams, motion: Motion, phi_trunk: ArrayLike, *, startup: ArrayLike = 1.0
) -> NDArray[np.float64]:
    """The 12 joint angles (..., 12) of the built-in model (joint order: docs/DESIGN.md §3)."""
    return joint_angles_with_flags(params, motion, phi_trunk, startup=startup).values
