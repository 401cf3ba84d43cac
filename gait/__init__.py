"""The ArtRo gait: Behnke's omnidirectional walk as adapted in seed 000, CA steering of seed 004.

Pure numpy. Two engines behind `joint_angles` (`gait.engine`, chosen by `GaitParams.engine`):
`behnke` -- motion vector -> walking phases (eqs 10–39) -> leg parameters (40–45) -> joint angles
(2–9) -- and `pfs`, seed 004's oscillator per joint (eqs 1–3, 10–11). Plus the differential-drive
path predictor and the motion ramp (seed 004's start-up phase). Everything is vectorised over the
trunk phase.
"""

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
    BalanceParams,
    ClockParams,
    GaitParams,
    LegParams,
    LoadParams,
    Motion,
    PfsParams,
    RampParams,
    ShiftParams,
    ShortParams,
    SteerParams,
    SwingParams,
    describe_fields,
    engine_groups,
    merge,
)
from gait.pfs import pfs_joint_angles_with_flags
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
