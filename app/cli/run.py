"""`artro run`: simulate a parameter set headless (optionally on a varied robot) and print the
run metrics of docs/DESIGN.md §6, as text or one JSON object."""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from collections.abc import Mapping, Sequence
from typing import Any

from app.cli.identify import add_script_options, check_script, record_script
from app.cli.options import (
    MAX_DURATION_S,
    add_motion_option,
    add_params_option,
    add_robot_option,
    check_pushed_variation,
    check_timing,
    motion_number,
    number,
    output_file_of,
    robot_and_set,
    subcommand,
    variation,
)
from app.params.document import ParameterSet
from app.robots.checks import SAFETY_FACTOR, eq1_torques
from app.robots.model import RobotModel
from app.robots.servos import rating_at
from app.robots.swap import ServoChoice, lightest_servo
from app.sim.fall_cause import OVER_STIFF, FallCause, fall_cause
from app.sim.headless import run
from app.worlds.fitted import fitted_variation
from app.worlds.variations import NOMINAL, Variation
from gait import ENGINES, Motion

EXAMPLES = """examples:
  artro run --motion a_p=0.07 --json       forward, the paper's case, metrics as JSON
  artro run --motion a_r=-0.1 --params tuned       step to the left, the tuned preset
  artro run --motion a_p=0.07,ca=0.1 --duration 60          curve walking
  artro run --motion a_p=0.07 --engine pfs --from-rest    seed 004's gait, from standing
  artro run --motion 0,0.07,0              the older triple AR,AP,AY: forward
  artro run --script identify --record rec.json --vary latency_ms=20,kp_scale=0.9
                                           a recording to fit (artro fit rec.json)

exit status: 0 the robot walked the whole run, 1 it fell (the metrics are printed all the same,
with a line on what to try on stderr), 2 bad input"""

#: the exit status of a run whose robot fell, so that a script can tell (2 is bad input)
FELL_STATUS = 1


def add_parser(sub: Any) -> None:
    r = subcommand(sub, "run", "simulate headless and print the run metrics", command, EXAMPLES)
    add_motion_option(r)
    r.add_argument(
        "--ca",
        type=motion_number("ca", "--ca"),
        default=None,
        help="curve amount, > 0 turns clockwise (default: the motion's)",
    )
    add_params_option(r)
    add_robot_option(r)
    seconds = number(0, MAX_DURATION_S, above=True, what="duration")
    r.add_argument("--duration", type=seconds, default=30.0, metavar="S", help="simulated seconds")
    warmup = number(0, MAX_DURATION_S, what="warmup")
    r.add_argument("--warmup", type=warmup, default=5.0, metavar="S", help="seconds not measured")
    r.add_argument(
        "--engine", choices=ENGINES, default=None, help="gait engine (default: the parameter set's)"
    )
    r.add_argument(
        "--from-rest",
        action="store_true",
        help="start standing (motion 0, CA 0) and ramp to the motion (the ramp parameters)",
    )
    r.add_argument(
        "--vary",
        type=variation,
        default=None,
        metavar="KEY=VALUE,...",
        help="walk a varied model, e.g. friction=0.4,latency_ms=40,tilt_deg=2,cal.l_knee=1.2 "
        "(docs/DESIGN.md §8; `artro bench robust` names its worst variations so) "
        "(default: none, the nominal model; a fitted robot's fit, docs/FIT.md)",
    )
    r.add_argument("--json", action="store_true", help="print the metrics as one JSON object")
    add_script_options(r, output_file_of((".json",), "a JSON recording"))
    r.set_defaults(parser_error=r.error)


def command(args: argparse.Namespace) -> int:
    check_script(args, args.parser_error)
    robot, pset = robot_and_set(args)
    if args.vary is None:
        args.vary = fitted_variation(robot)  # a fitted robot walks its fit (docs/FIT.md)
    if robot.description.fitted is not None and args.vary == fitted_variation(robot):
        print(f"{robot.name} is fitted to {robot.description.fitted.recording}: walking its fit "
              f"({args.vary.name}); --vary replaces it", file=sys.stderr)  # fmt: skip
    if args.script is not None:
        return record_script(args, robot, pset)
    motion = pset.motion
    if args.motion is not None:
        motion = args.motion.applied(motion, args.ca)
    elif args.ca is not None:
        motion = dataclasses.replace(motion, ca=args.ca)
    gait = pset.gait if args.engine is None else dataclasses.replace(pset.gait, engine=args.engine)
    check_timing((), gait, args.duration, args.warmup)  # a whole cycle to measure
    check_pushed_variation(args.vary, args.duration, f"--duration {args.duration:g}")
    start = Motion() if args.from_rest else None
    result = run(
        gait,
        motion,
        duration_s=args.duration,
        warmup_s=args.warmup,
        start_motion=start,
        robot=robot,
        variation=args.vary,
    )
    m = result.metrics
    if result.diagnosis:  # one line, on stderr also with --json
        cause = fall_cause(gait, motion, args.vary, m["fall_time_s"], robot=robot,
                           duration_s=args.duration, warmup_s=args.warmup,
                           start_motion=start)  # fmt: skip
        said = f"; {cause.line()}" if cause else ""
        advice = fall_advice(robot, pset, result.stuck, args.robot or "artro", cause, args.vary)
        print(f"artro run: {result.diagnosis}{said}: try {advice}", file=sys.stderr)
    if args.json:
        named = {"robot": robot.name, "variation": args.vary.name}
        print(json.dumps({**m, **named}, allow_nan=False))
        return exit_status(m)
    print(
        f"robot {robot.name!r}, parameter set {pset.name!r} ({gait.engine}), motion "
        f"a_r={motion.a_r} a_p={motion.a_p} a_y={motion.a_y} CA={motion.ca}"
        + (", ramped from rest" if args.from_rest else "")
        + ("" if args.vary.is_nominal else f", varied: {args.vary.name}")
    )
    if m["fell"]:
        print(f"FELL after {m['fall_time_s']} s")
    if m["forward_cm_s"] is not None:
        print(
            f"forward {m['forward_cm_s']:+.2f} cm/s, lateral {m['lateral_cm_s']:+.2f} cm/s (left +)"
        )
        print(
            f"turn {m['turn_deg_s']:+.2f} deg/s (CCW +), differential drive predicts "
            f"{m['predicted_turn_deg_s']:+.2f} deg/s, path error {m['path_error_cm']:.2f} cm"
        )
        print(f"gyro RMS {m['gyro_rms']:.3f} rad/s")
    print(f"{m['sim_s']:.1f} s simulated in {m['wall_s']:.2f} s: {m['rtf']:.1f}x real time")
    print(servo_load_line(robot, list(result.required_torque_nm), m))
    flags = {k: v for k, v in m["flags"].items() if v}
    if flags:
        print(f"flags: {flags}")
    return exit_status(m)


def exit_status(metrics: Mapping[str, Any]) -> int:
    """0 when the robot walked the whole run, FELL_STATUS when it fell."""
    return FELL_STATUS if metrics["fell"] else 0


def fall_advice(
    robot: RobotModel,
    pset: ParameterSet,
    stuck: Sequence[str],
    where: str,
    cause: FallCause | None = None,
    variation: Variation = NOMINAL,
) -> str:
    """What to try after a fall, by what the run shows: the part of the variation that felled
    it (`cause`: a push, a sensor error, the servos' departures ...), else a servo held at its
    torque (`stuck`, the joints the run shows), else the gait; never a command that would then
    say there is nothing to do: `robot check --suggest` only where eq (1) finds a servo short
    (it swaps only those), a tune only where the set in use was not tuned for this robot
    (`where`: its name or file). A servo eq (1) finds short that did not hold the fall is a
    note, not the fix."""
    if cause is not None and cause.names:
        return " or ".join(
            part_advice(part, stuck, robot, variation, where) for part in cause.names
        )
    short = [t.joint for t in eq1_torques(robot.description) if t.margin < 0]
    held_short = [j for j in stuck if j in short]  # held the fall, and short by eq (1)
    held_carried = [j for j in stuck if j not in short]  # held it, though eq (1) carries them
    tries = []
    if held_short:  # the servos that held the fall first, then eq (1)'s other short ones
        named = held_short + [j for j in short if j not in held_short]
        joints = ", ".join(named[:4]) + (f" (+{len(named) - 4} more)" if len(named) > 4 else "")
        tries.append(f"stronger servos on {joints} (artro robot check {where} --suggest)")
    if held_carried:
        tries.append(stronger_line(robot, held_carried))
    if pset.robot != robot.name:
        tries.append(f"a gait tuned for this robot (artro tune --robot {where})")
    else:
        tries.append(
            f"a smaller motion, or a longer tune of {pset.name!r} (artro tune --robot {where} "
            f"--base {pset.name} with more --generations)"
        )
    text = " or ".join(tries)
    if short and not held_short:
        which = "no servo's torque held" if not stuck else "no servo eq (1) finds short held"
        text += (
            f" (apart from this fall, which {which}: eq (1) finds {', '.join(short[:4])} short, "
            f"artro robot check {where} --suggest)"
        )
    return text


def stronger_line(robot: RobotModel, stuck: Sequence[str]) -> str:
    stronger = stronger_servo(robot, stuck[0])
    named = f"the {stronger.name} of the table, or " if stronger else ""
    return (
        f"stronger servos on {', '.join(stuck[:3])} (eq (1) carries them standing, walking "
        f"asks more: {named}a servo of your own in the file's `servos`)"
    )


def part_advice(
    part: str, stuck: Sequence[str], robot: RobotModel, variation: Variation, where: str
) -> str:
    """What to try where `part` of the variation felled the run."""
    tune = f"artro tune --robot {where} --robust 8"
    if part == "push":
        return (
            f"a gait tuned on such pushes ({tune} --range push_n_s=0:{variation.push_n_s:g}), "
            "or no push that strong"
        )
    if part == "sensor error":
        return "a calibrated IMU (the laws act on what it reads), or the set with its laws off"
    if part == "servos":
        if stuck and variation.torque_scale < 1.0:
            return stronger_line(robot, stuck)
        if variation.kp_scale > OVER_STIFF:
            return (
                f"servos no stiffer than the servo rule's (kp {variation.kp_scale:g} x its), "
                f"or a gait tuned on them ({tune} --range kp_scale=1:{variation.kp_scale:g})"
            )
        return f"servos nearer the model's (their play, delay, calibration), or {tune}"
    return f"a gait tuned on such worlds ({tune})"


def stronger_servo(robot: RobotModel, joint: str) -> ServoChoice | None:
    """The lightest servo of the table (and the file's) that gives (1 + SAFETY_FACTOR) times
    the stall torque of `joint`'s servo, as `bench robust` sizes one for a servo at its limit."""
    desc = robot.description
    servos = desc.servo_catalogue()
    servo = desc.joint_servo(joint)
    stall = rating_at(servos[servo], desc.supply_voltage_v, servo)[0]
    return lightest_servo((1 + SAFETY_FACTOR) * stall, desc.supply_voltage_v, servos=servos)


def servo_load_line(robot: RobotModel, names: list[str], m: Mapping[str, Any]) -> str:
    """The servos' load as measured: the highest peak torque against its stall torque, and the
    servos that sat at their limit (a servo cannot give more than its stall torque, so a peak
    there says only that it needed at least that: eq (1)'s static check is `robot check`)."""
    stall = robot.model.actuator_forcerange[:, 1]
    peaks, limits = m["peak_torque_nm"], m["at_limit_share"]
    top = max(range(len(names)), key=lambda i: peaks[i] / stall[i])
    line = (
        f"servo load: peak {peaks[top]:.2f} N m at {names[top]}, "
        f"{peaks[top] / stall[top]:.0%} of its stall torque"
    )
    held = sorted((i for i in range(len(names)) if limits[i] > 0), key=lambda i: -limits[i])
    if held:
        shares = ", ".join(f"{names[i]} {limits[i]:.0%}" for i in held[:4])
        more = f" (+{len(held) - 4} more)" if len(held) > 4 else ""
        line += f"; at their limit (share of frames): {shares}{more}"
    return line
