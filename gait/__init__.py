"""The ArtRo gait, pure numpy: two engines behind `joint_angles` -- `behnke` (seed 000 eqs 2–45, CA
of seed 004) and `pfs` (seed 004's oscillators, eqs 1–3, 10–11) -- the differential-drive path
predictor and the motion ramp, vectorised over the trunk phase (docs/DESIGN.md §4)."""

from gait.engine import joint_angles, joint_angles_with_flags, startup_gain
from gait.leg_interface import (
    ARTRO_LEG,
    JOINT_NAMES,
    JointAngles,
    LegGeometry,
    behnke_joint_angles_with_flags,
    knee_triangle,
    leg_to_joint_angles,
)
from gait.params import (
    ENGINES,
    GROUP_NAMES,
    PHASE_GROUPS,
    ClockParams,
    GaitParams,
    Motion,
    PfsParams,
    RampParams,
    SteerParams,
    describe_fields,
    engine_groups,
    merge,
)
from gait.pfs import pfs_joint_angles_with_flags
from gait.phase_params import (
    BalanceParams,
    LegParams,
    LoadParams,
    ShiftParams,
    ShortParams,
    SwingParams,
)
from gait.phases import (
    LegParameters,
    advance_phase,
    leg_parameters,
    leg_parameters_with_flags,
    leg_phases,
    pi_cut,
    swing_profile,
)
from gait.ramp import ramp_motion, ramp_steps
from gait.steering import (
    Pose2D,
    curve_amount_for,
    predict_path,
    turn_radius_m,
    turn_rate_rad_s,
)

__all__ = [
    "ARTRO_LEG",
    "ENGINES",
    "GROUP_NAMES",
    "JOINT_NAMES",
    "PHASE_GROUPS",
    "BalanceParams",
    "ClockParams",
    "GaitParams",
    "JointAngles",
    "LegGeometry",
    "LegParameters",
    "LegParams",
    "LoadParams",
    "Motion",
    "PfsParams",
    "Pose2D",
    "RampParams",
    "ShiftParams",
    "ShortParams",
    "SteerParams",
    "SwingParams",
    "advance_phase",
    "behnke_joint_angles_with_flags",
    "curve_amount_for",
    "describe_fields",
    "engine_groups",
    "joint_angles",
    "joint_angles_with_flags",
    "knee_triangle",
    "leg_parameters",
    "leg_parameters_with_flags",
    "leg_phases",
    "leg_to_joint_angles",
    "merge",
    "pfs_joint_angles_with_flags",
    "pi_cut",
    "predict_path",
    "ramp_motion",
    "ramp_steps",
    "startup_gain",
    "swing_profile",
    "turn_radius_m",
    "turn_rate_rad_s",
]
