"""The `artro` command line: serve, run, export, bench, tune (`artro COMMAND --help` for each)."""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from app.core.axle_fit import walking_amplitude
from app.core.ca_calibration import CalibrationError, calibrate_ca, with_k
from app.core.evaluation import evaluator_for
from app.core.headless import run
from app.core.mcu.build import export_firmware_folder
from app.core.mcu.cli import add_firmware_parser, cmd_firmware, wiring
from app.core.robot import RobotModel
from app.core.variations import NOMINAL, Variation, parse_variation
from app.params.document import ParameterSet, load_parameter_set
from app.params.formats import FORMATS, export_text
from app.robot_cli import (
    add_robot_option,
    add_robot_parser,
    cmd_robot,
    starting_set,
    warn_if_other_robot,
)
from app.robot_link import add_link_parser, cmd_link
from app.study import bench as paper_bench
from app.study import tune
from gait import ENGINES, Motion


def _motion_triple(text: str) -> tuple[float, float, float]:
    parts = text.split(",")
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(
            f"expected three numbers a_r,a_p,a_y such as 0,0.07,0; got {text!r}"
        )
    return values  # type: ignore[return-value]


EXAMPLES = {
    "serve": """examples:
  artro serve                              the dashboard on http://localhost:8000
  artro serve --params my_gait.json --port 9000
  artro serve --drive firmware             pulses from the robot's firmware on an emulated MCU""",
    "run": """examples:
  artro run --motion 0,0.07,0 --json       forward, the paper's case, metrics as JSON
  artro run --motion -0.1,0,0 --params models/presets/tuned.json   step to the left
  artro run --motion 0,0.07,0 --ca 0.1 --duration 60               curve walking
  artro run --motion 0,0.07,0 --engine pfs --from-rest    seed 004's gait, from standing""",
    "export": """examples:
  artro export --format c -o artro_params.h              the firmware header
  artro export --format yaml --params my_gait.json
  artro export --format firmware --params my_gait.json -o my_robot   then: make -C my_robot""",
    "calibrate-ca": """examples:
  artro calibrate-ca                       the paper gait, forward at a_p = 0.07
  artro calibrate-ca --params models/presets/tuned.json -o tuned_steered.json""",
    "bench": """examples:
  artro bench paper                        both presets, 60 s runs (~4 min on 2 cores)
  artro bench paper --quick --presets tuned""",
    "firmware": """examples:
  artro firmware build -o artro_firmware     sources, generated headers, Makefile; built
  artro firmware run --motion 0,0.07,0 --frames 251 --json   pins against the model
  artro firmware run --pty                   the emulated robot on a pseudo-terminal""",
    "link": """examples:
  artro link --port /dev/ttyUSB0             follow the dashboard on http://127.0.0.1:8000
  artro link --port /dev/pts/5 --params models/presets/tuned.json   send one set
  artro link --dry-run                       print the messages it would send""",
    "tune": """examples:
  artro tune --base paper --tune swing.v,short.amp_base --generations 4 --popsize 6
  artro tune --base models/presets/tuned.json --set leg.paper_signs=false --select passing""",
}
_NUMBERS = re.compile(r"^-\d*\.?\d+(e[-+]?\d+)?(,[-+]?\d*\.?\d+(e[-+]?\d+)?)*$", re.IGNORECASE)


def _variation(text: str) -> Variation:
    try:
        return parse_variation(text)
    except (ValueError, TypeError) as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def join_negative_values(argv: Sequence[str]) -> list[str]:
    """`--motion -0.1,0,0` -> `--motion=-0.1,0,0`: argparse would take the value for an option."""
    out: list[str] = []
    for token in argv:
        if out and out[-1].startswith("--") and "=" not in out[-1] and _NUMBERS.match(token):
            out[-1] = f"{out[-1]}={token}"
        else:
            out.append(token)
    return out


def _subcommand(sub: Any, name: str, help_text: str) -> argparse.ArgumentParser:
    return sub.add_parser(
        name,
        help=help_text,
        description=help_text,
        epilog=EXAMPLES.get(name),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="artro",
        description="ArtRo Gait Studio: tune the ArtRo biped's gait in a MuJoCo simulation.",
        epilog="Directions: a_p > 0 walks forward, a_r > 0 steps to the right, a_y > 0 and "
        "CA > 0 turn clockwise.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    s = _subcommand(sub, "serve", "the dashboard: simulation, API, 3D view and scope page")
    s.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1)")
    s.add_argument("--port", type=int, default=8000, help="HTTP port of the dashboard and API")
    s.add_argument("--viser-port", type=int, default=8080, help="port of the viser 3D view")
    s.add_argument("--params", metavar="FILE", help="start with this parameter set")
    add_robot_option(s)
    s.add_argument(
        "--cluster",
        metavar="tcp://HOST:PORT",
        help="run the dashboard's robustness job on this Dask scheduler (docs/CLUSTER.md)",
    )
    s.add_argument("--data-dir", metavar="DIR", help="where presets are kept")
    s.add_argument("--no-viewer", action="store_true", help="run without the viser 3D view")
    s.add_argument(
        "--drive",
        choices=("model", "firmware"),
        default="model",
        help="who makes the servo pulses: the Python hardware model (default) or the robot's "
        "firmware on an emulated ATmega128 (needs gcc-avr and simavr); switchable in the page",
    )
    s.add_argument(
        "--allowed-host",
        action="append",
        default=[],
        metavar="NAME",
        help="also serve requests for this Host name (repeatable); localhost, 127.0.0.1, ::1 "
        "and the bind host always are, others are refused against DNS rebinding",
    )
    r = _subcommand(sub, "run", "simulate headless and print the run metrics")
    r.add_argument(
        "--motion",
        type=_motion_triple,
        default=None,
        metavar="AR,AP,AY",
        help="motion vector; a_r > 0 steps right, a_p > 0 walks forward, a_y > 0 turns clockwise "
        "(default: the parameter set's)",
    )
    r.add_argument("--ca", type=float, default=None, help="curve amount, > 0 turns clockwise")
    r.add_argument(
        "--params",
        metavar="FILE",
        help="parameter-set JSON or a built-in preset's name (default: the --robot's default "
        "preset, else paper values)",
    )
    add_robot_option(r)
    seconds = tune.number(0, tune.MAX_DURATION_S, above=True, what="duration")
    r.add_argument("--duration", type=seconds, default=30.0, metavar="S", help="simulated seconds")
    warmup = tune.number(0, tune.MAX_DURATION_S, what="warmup")
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
        type=_variation,
        default=NOMINAL,
        metavar="KEY=VALUE,...",
        help="walk a varied model, e.g. friction=0.4,latency_ms=40,tilt_deg=2,cal.l_knee=1.2 "
        "(docs/DESIGN.md §13; `artro bench robust` names its worst variations so)",
    )
    r.add_argument("--json", action="store_true", help="print the metrics as one JSON object")
    e = _subcommand(sub, "export", "write a parameter set as JSON, YAML or a firmware C header")
    e.add_argument(
        "--format",
        required=True,
        choices=(*FORMATS, "firmware"),
        help="output format; firmware: a folder with the C sources, this set's header and a "
        "Makefile (make, make flash) -- needs -o DIR",
    )
    e.add_argument("--params", metavar="FILE", help="parameter-set JSON (default: paper values)")
    add_robot_option(e)
    e.add_argument("-o", "--output", metavar="FILE", help="write here (default: standard output)")
    c = _subcommand(
        sub,
        "calibrate-ca",
        "fit the steering term K (steer.yaw_per_ca) and the effective axle b_eff from curve walks",
    )
    c.add_argument("--params", metavar="FILE", help="parameter-set JSON (default: paper values)")
    add_robot_option(c)
    c.add_argument("--engine", choices=ENGINES, default=None, help="gait engine to calibrate")
    c.add_argument(
        "--a-p", type=float, default=None, help="forward amplitude to walk at (default: the set's)"
    )
    c.add_argument("--duration", type=float, default=20.0, metavar="S", help="seconds per walk")
    c.add_argument("--warmup", type=float, default=4.0, metavar="S", help="seconds not measured")
    c.add_argument("--iterations", type=int, default=2, help="checks of a fitted K (default 2)")
    c.add_argument(
        "--direction",
        choices=("forward", "backward", "both"),
        default="both",
        help="which K to fit: walking forward (steer.yaw_per_ca), backward "
        "(steer.yaw_per_ca_backward), or both (default; a given --a-p picks its own)",
    )
    c.add_argument("--threads", type=int, default=None, help="simulation threads (default: all)")
    c.add_argument("--cluster", metavar="tcp://HOST:PORT", help="evaluate on this Dask scheduler")
    c.add_argument("-o", "--output", metavar="FILE", help="write the parameter set with K here")
    c.add_argument("--json", action="store_true", help="print the result as one JSON object")
    b = _subcommand(sub, "bench", "simulate what the papers measured and compare (tables, PNGs)")
    paper_bench.add_arguments(b)
    t = _subcommand(sub, "tune", "CMA-ES over gait parameters toward the paper's walking")
    tune.add_arguments(t)
    fw = add_firmware_parser(sub)
    fw.epilog = EXAMPLES["firmware"]
    add_link_parser(sub, EXAMPLES["link"])
    add_robot_parser(sub)
    return parser


def _robot_and_set(args: argparse.Namespace) -> tuple[RobotModel, ParameterSet]:
    robot = RobotModel.load(args.robot)
    pset = starting_set(robot, args.params, robot_given=args.robot is not None)
    warn_if_other_robot(pset, robot)
    return robot, pset


def _cmd_run(args: argparse.Namespace) -> int:
    robot, pset = _robot_and_set(args)
    motion = pset.motion
    if args.motion is not None:
        a_r, a_p, a_y = args.motion
        motion = dataclasses.replace(motion, a_r=a_r, a_p=a_p, a_y=a_y)
    if args.ca is not None:
        motion = dataclasses.replace(motion, ca=args.ca)
    gait = pset.gait if args.engine is None else dataclasses.replace(pset.gait, engine=args.engine)
    tune.check_timing((), gait, args.duration, args.warmup)  # a whole cycle to measure
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
    if args.json:
        named = {"robot": robot.name, "variation": args.vary.name}
        print(json.dumps({**m, **named}, allow_nan=False))
        return 0
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
    peak = max(result.required_torque_nm.items(), key=lambda kv: kv[1])
    print(f"largest required servo torque (eq 1, sf 0.2): {peak[1]:.2f} N m at {peak[0]}")
    flags = {k: v for k, v in m["flags"].items() if v}
    if flags:
        print(f"flags: {flags}")
    return 0


def _cmd_calibrate_ca(args: argparse.Namespace) -> int:
    robot, pset = _robot_and_set(args)
    gait = pset.gait if args.engine is None else dataclasses.replace(pset.gait, engine=args.engine)
    motion = pset.motion if args.a_p is None else dataclasses.replace(pset.motion, a_p=args.a_p)
    size = abs(walking_amplitude(motion))
    signs = {"forward": (1.0,), "backward": (-1.0,), "both": (1.0, -1.0)}[args.direction]
    if args.a_p is not None and args.direction == "both":
        signs = (1.0 if args.a_p >= 0 else -1.0,)  # a given a_p names its direction
    log = sys.stderr if args.json else sys.stdout
    results, failed = {}, {}
    for sign in signs:
        a_p, direction = sign * size, "forward" if sign > 0 else "backward"
        try:
            result = calibrate_ca(
                gait,
                dataclasses.replace(motion, a_p=a_p),
                evaluator_for(robot, cluster=args.cluster, threads=args.threads),
                duration_s=args.duration,
                warmup_s=args.warmup,
                iterations=args.iterations,
                say=lambda line: print(line, file=log, flush=True),
            )
        except CalibrationError as exc:
            if len(signs) == 1:
                raise
            failed[direction] = str(exc)  # the other direction may still calibrate
            print(f"{direction}: no calibration, K left as it was: {exc}", file=log, flush=True)
            continue
        gait = with_k(gait, a_p, result.yaw_per_ca)
        results[direction] = result
    if not results:
        raise CalibrationError("; ".join(f"{d}: {e}" for d, e in failed.items()))
    if args.output:
        out = dataclasses.replace(pset, gait=gait, created="", project_version="")
        text, _media, _name = export_text(out, "json")
        Path(args.output).write_text(text, encoding="utf-8")
    if args.json:
        document = {d: r.to_dict() for d, r in results.items()}
        document |= {d: {"error": e} for d, e in failed.items()}
        print(json.dumps(document, allow_nan=False))
        return 0

    def cm(m: float | None) -> str:
        if m is None:
            return "none (CA does not turn it)"
        return f"{100 * m:.1f} cm" + (" (CA turns it the other way)" if m < 0 else "")

    for direction, result in results.items():
        print(
            f"{direction}: steer.{result.field} = K = {result.yaw_per_ca:+.4f} for {pset.name!r} "
            f"({gait.engine}) at a_p = {result.a_p:+.3f}: CA turns it at "
            f"{100 * result.gain:.0f} % of eq (13)"
            + ("" if result.converged else " (not within 10 %)")
        )
        print(
            f"  b_eff = {cm(result.axle_eff_m)} with K (feet {100 * result.feet_m:.1f} cm apart; "
            f"without K: {cm(result.axle_eff_without_m)}), V = {100 * result.speed_m_s:.2f} cm/s, "
            f"{result.sim_s:.0f} s simulated"
        )
    if args.output:
        print(f"wrote {args.output}")
    return 0


def _cmd_export(args: argparse.Namespace) -> int:
    robot, pset = _robot_and_set(args)
    if args.format == "firmware":
        if not args.output:
            raise ValueError("--format firmware writes a folder: give it with -o DIR")
        folder = export_firmware_folder(pset.to_dict(), Path(args.output), **wiring(robot))
        print(f"{folder}: the firmware for {pset.name or 'the paper set'}; `make` builds it")
        return 0
    text, _media_type, _filename = export_text(pset, args.format)
    if args.output:
        Path(args.output).write_text(text, encoding="utf-8")
    else:
        sys.stdout.write(text)
    return 0


def _cmd_serve(args: argparse.Namespace) -> int:
    import uvicorn

    from app.params.presets import default_data_dir
    from app.server.app import create_app
    from app.server.services import ServerConfig
    from app.server.viser_view import viser_url

    config = ServerConfig(
        host=args.host,
        port=args.port,
        viser_port=args.viser_port,
        params_file=Path(args.params) if args.params else None,
        robot=args.robot,
        cluster=args.cluster,
        data_dir=Path(args.data_dir) if args.data_dir else default_data_dir(),
        viewer=not args.no_viewer,
        allowed_hosts=tuple(args.allowed_host),
        drive=args.drive,
    )
    RobotModel.load(args.robot)  # fail here, clearly, naming the field, not inside the server
    if config.params_file:
        load_parameter_set(config.params_file)
    if config.drive == "firmware":
        from app.core.mcu.build import missing_tools

        if missing := missing_tools():
            print(f"artro serve --drive firmware: missing {', '.join(missing)}", file=sys.stderr)
            print("install them with: bash scripts/setup.sh", file=sys.stderr)
            return 2
    app = create_app(config)
    url = viser_url(args.host, args.port)
    print(
        f"ArtRo Gait Studio: {url}  (3D view alone: {viser_url(args.host, args.viser_port)}, "
        f"API docs: {url}/docs)",
        flush=True,
    )
    # WebSocket clients only listen: a message larger than this closes their socket
    uvicorn.run(app, host=args.host, port=args.port, log_level="warning", ws_max_size=65536)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(join_negative_values(sys.argv[1:] if argv is None else argv))
    try:
        if args.command == "run":
            return _cmd_run(args)
        if args.command == "serve":
            return _cmd_serve(args)
        if args.command == "export":
            return _cmd_export(args)
        if args.command == "calibrate-ca":
            return _cmd_calibrate_ca(args)
        if args.command == "bench":
            return paper_bench.cmd_bench(args)
        if args.command == "tune":
            return tune.command(args)
        if args.command == "firmware":
            return cmd_firmware(args)
        if args.command == "link":
            return cmd_link(args, sys.stdout)
        if args.command == "robot":
            return cmd_robot(args)
    # RuntimeError: BuildError, EmulatorError, LinkError, CalibrationError
    except (ValueError, OSError, RuntimeError) as exc:
        parser.exit(2, f"artro {args.command}: error: {exc}\n")
    return 1


if __name__ == "__main__":
    sys.exit(main())
