"""The ArtRo gait: Behnke's omnidirectional walk as adapted in seed 000, CA steering of seed 004.

Pure numpy. Motion vector -> walking phases (eqs 10–39) -> leg parameters (40–45) -> joint angles
(2–9); plus the differential-drive path predictor and the motion ramp (seed 004's start-up
phase). Everything is vectorised over the trunk phase.
"""

from gait.leg_interface import (
    ARTRO_LEG,
    JOINT_NAMES,
    JointAngles,
    LegGeometry,
    joint_angles,
    joint_angles_with_flags,
    knee_triangle,
    leg_to_joint_angles,
)
from gait.params import (
    PHASE_GROUPS,
    BalanceParams,
    ClockParams,
    GaitParams,
    LegParams,
    LoadParams,
    Motion,
    RampParams,
    ShiftParams,
    ShortParams,
    SteerParams,
    SwingParams,
    describe_fields,
    merge,
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
    "Pose2D",
    "RampParams",
    "ShiftParams",
    "ShortParams",
    "SteerParams",
    "SwingParams",
    "advance_phase",
    "curve_amount_for",
    "describe_fields",
    "joint_angles",
    "joint_angles_with_flags",
    "knee_triangle",
    "leg_parameters",
    "leg_parameters_with_flags",
    "leg_phases",
    "leg_to_joint_angles",
    "merge",
    "pi_cut",
    "predict_path",
    "ramp_motion",
    "ramp_steps",
    "swing_profile",
    "turn_radius_m",
    "turn_rate_rad_s",
]
