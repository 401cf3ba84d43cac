"""Whether a robust case's failures are a servo's torque (time at its limit, failing against
passing runs), the swaps eq (1) asks for, one per group of joints with the same servo, and the
robot with them swapped in (docs/DESIGN.md §7, §12)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from app.robots.description import RobotDescription
from app.robots.swap import derived, derived_name, lightest_servo, mirror, with_servo
from app.sim.headless import AT_LIMIT
from gait import JOINT_NAMES
from hardware import SAFETY_FACTOR

#: a joint holds a case back when its failing runs sit at its limit for a larger share of their
#: frames than the passing runs, by this many standard errors, and for at least this share
LIMIT_Z = 2.0
MIN_LIMIT_SHARE = 0.05


def torque_bound(
    failed: Sequence[Mapping[str, Any]],
    passed: Sequence[Mapping[str, Any]],
    nominal: Mapping[str, Any],
    stall_nm: Sequence[float] | None,
    torque_scales: Sequence[float] | None = None,
) -> dict[str, Any] | None:
    """Whether a case's failures are a servo's torque. Every run has its servos at their limit
    now and then (the knees at each step), so a peak at the stall torque says little; what
    tells is time: a joint is at its limit when the failing runs spend a larger share of their
    frames there (`at_limit_share`) than the passing runs do, by at least LIMIT_Z standard
    errors and at least MIN_LIMIT_SHARE (the nominal run is the reference when fewer than two
    pass). Also the failing runs with a peak at AT_LIMIT of their own stall torque (`stall_nm`,
    the robot as described, times each run's `torque_scale`) and the largest peak; None
    without failures or figures."""
    if not failed or stall_nm is None:
        return None
    scales = np.ones(len(failed)) if torque_scales is None else np.asarray(torque_scales)
    own_stall = scales[:, None] * np.asarray(stall_nm)[None, :]
    peaks = np.asarray([m["peak_torque_nm"] for m in failed])
    share = np.asarray([m["at_limit_share"] for m in failed])
    out: dict[str, Any] = {
        "failing_runs": len(failed),
        "at_stall_runs": int((peaks >= AT_LIMIT * own_stall).any(axis=1).sum()),
        "joints": [],
        "at_limit_share": {},
        "peak_nm": float(peaks.max()),
        "reference": "passing runs" if len(passed) >= 2 else "the nominal run",
    }
    ref = np.asarray(
        [m["at_limit_share"] for m in passed] if len(passed) >= 2 else [nominal["at_limit_share"]]
    )
    if len(failed) >= 2:
        var = share.var(axis=0, ddof=1) / len(share)
        if len(ref) >= 2:
            var = var + ref.var(axis=0, ddof=1) / len(ref)
        more = share.mean(axis=0) - ref.mean(axis=0)
        for j, name in enumerate(JOINT_NAMES):
            fail_share = float(share[:, j].mean())
            if fail_share >= MIN_LIMIT_SHARE and more[j] > LIMIT_Z * math.sqrt(var[j]):
                out["joints"].append(name)
                out["at_limit_share"][name] = [fail_share, float(ref[:, j].mean())]
    out["bound"] = bool(out["joints"])
    return out


def servo_advice(report: dict[str, Any], robot: RobotDescription, stall_nm: Sequence[float]):
    """The servo swaps a preset's torque-bound cases ask for, one per group of joints with the
    same servo (a servo's figures are its own: an MG90S hip yaw and MG995 knees at their limits
    are two swaps, never one): the joints at their limit and their mirror joints where both legs
    have that servo (a robot built alike on both sides stays so), eq (1)'s torque for the group
    ((1 + sf) x the stall torque its joints reached, `stall_nm` per joint: what they were asked
    is at least that) and the lightest servo of the table or the robot's file that gives it at
    its supply (None where none does); None if no case is torque-bound."""
    cases = [c for c in report["cases"] if c["torque"] and c["torque"]["bound"]]
    if not cases:
        return None
    bound = {j for c in cases for j in c["torque"]["joints"]}
    bound |= {mirror(j) for j in bound if robot.joint_servo(mirror(j)) == robot.joint_servo(j)}
    by_servo: dict[str, list[str]] = {}
    for joint in JOINT_NAMES:  # the gait's order, left leg first
        if joint in bound:
            by_servo.setdefault(robot.joint_servo(joint), []).append(joint)
    groups = []
    for servo, joints in by_servo.items():
        reached = max(stall_nm[JOINT_NAMES.index(j)] for j in joints)
        need = (1.0 + SAFETY_FACTOR) * reached
        choice = lightest_servo(need, robot.supply_voltage_v, servos=robot.servo_catalogue())
        groups.append(
            {
                "joints": joints,
                "servo_now": servo,
                "stall_nm": reached,
                "need_nm": need,
                "servo": None if choice is None else choice.name,
                "servo_stall_nm": None if choice is None else choice.stall_torque_nm,
            }
        )
    return {"cases": [c["case"] for c in cases], "groups": groups}


def advised_robot(robot: RobotDescription, advice: dict[str, Any]) -> RobotDescription | None:
    """`robot` with the servos `servo_advice` names swapped in, group by group (a stated total
    mass moved by each servo's difference), named `<name>-advised`; None where no group has a
    servo that carries it."""
    swapped = robot
    for group in advice["groups"]:
        if group["servo"] is not None:
            swapped = with_servo(swapped, group["joints"], group["servo"])
    if swapped is robot:
        return None
    changes = "; ".join(
        f"{g['servo']} on {', '.join(g['joints'])}" for g in advice["groups"] if g["servo"]
    )
    return derived(swapped, derived_name(robot.name, "advised"), f"{robot.title}; {changes}")
