"""`artro tune`: CMA-ES over chosen gait parameters toward the paper's measured walking,
optionally scored on varied robots too; the study resumes from its store, the best set is saved
as a preset file; without `--base`, the start for the robot and its recipe (`command`;
docs/DESIGN.md §12)."""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import Any, TextIO

from app.analysis.cases import (
    SPEED_TOLERANCE,
    SPOT_DRIFT_LIMIT_CM_S,
    STEERING_TOLERANCE,
    speed_scale_of,
)
from app.analysis.robot_start import start_for, walks
from app.analysis.robot_tune import RESULT, START, EventWriter, result_figures, tuned_name
from app.cli.options import (
    backend_of,
    check_timing,
    cluster_of,
    ranges_from,
    resolve_set,
)
from app.cli.tune_options import CLASSIC, DEFAULT_OUT, RECIPE
from app.cli.tune_options import add_parser as add_options
from app.evaluation import close_evaluator, evaluator_for
from app.params.document import ParameterSet
from app.params.presets import (
    PresetError,
    PresetNotFound,
    PresetStore,
    builtin_presets,
    check_name,
    default_data_dir,
    stamped,
    write_parameter_set,
)
from app.robots.checks import eq1_torques
from app.robots.model import RobotModel
from app.study.study_store import StudyStore, study_name_for
from app.study.tune import Tuner
from app.study.tune_choice import best_passing, best_walking, families_of, varied_summary
from app.study.tune_loss import LossWeights
from gait.params import merge, parse_settings


def fill_defaults(args: argparse.Namespace) -> bool:
    """Set every search option left out (None) to the recipe's value (no `--base`: True
    returned) or the classic one."""
    start = args.base is None
    for key, value in (RECIPE if start else CLASSIC).items():
        if getattr(args, key) is None:
            setattr(args, key, value)
    return start


def default_name(robot: str, builtins: Iterable[str]) -> str:
    """`tuned-ROBOT` (`app.analysis.robot_tune.tuned_name`), checked as a preset name."""
    return check_name(tuned_name(robot, builtins))


def result_name(given: str | None, robot: str) -> str:
    """The saved preset's name: `--name` (a valid name, not a built-in's) or `default_name`."""
    builtins = list(builtin_presets())
    if given is None:
        return default_name(robot, builtins)
    check_name(given)  # PresetError (a ValueError) says what a name may be
    if given in builtins:
        raise ValueError(
            f"--name {given} is a built-in preset's name, and built-ins are read-only "
            f"({', '.join(builtins)}): give another name, or leave --name out for "
            f"{default_name(robot, builtins)}"
        )
    return given


def add_parser(sub: Any) -> None:
    add_options(sub, command)


def command(args: argparse.Namespace) -> int:
    """The tune (`tune`); with `--events -` standard output carries the events alone, and what
    is said for a person goes to standard error."""
    if args.events != "-":
        return tune(args, events_to=None)
    events_to = sys.stdout
    with contextlib.redirect_stdout(sys.stderr):
        return tune(args, events_to=events_to)


def tune(args: argparse.Namespace, events_to: Any) -> int:
    """Without `--base`: the start for the robot (`app.analysis.robot_start`), the built-in
    preset nearest its leg length with its clock scaled by √(L_ref/L), tuned by `START_RECIPE`
    (every search option left out takes the recipe's value: 8 fields, 10 generations of 8, 20 s
    runs, the lowest loss that never fell); the result saved among the presets
    (`$ARTRO_DATA_DIR/presets`) as `tuned-ROBOT` and to `--out` when given. With `--base`, the
    options left out take `CLASSIC`'s values and the result goes to `--out` (default
    out/tune/NAME.json)."""
    start_mode = fill_defaults(args)
    robot = RobotModel.load(args.robot)
    name = result_name(args.name, robot.name)  # refused before anything runs
    args.short_servos = [t.joint for t in eq1_torques(robot.description) if t.margin < 0]
    if args.short_servos:  # no gait walks on servos that cannot hold the robot standing
        print(
            f"warning: eq (1) finds the servos of {', '.join(args.short_servos)} short; a tune "
            f"cannot make up for them: artro robot check {args.robot or robot.name} --suggest",
            file=sys.stderr,
        )
    if start_mode:
        start = start_for(robot.description, builtin_presets())
        print(start.describe())
        base = ParameterSet(name=start.preset, robot=robot.name, gait=start.gait)
    else:
        base = resolve_set(args.base, "--base").pset
    base = dataclasses.replace(base, gait=merge(base.gait, parse_settings(args.set)))
    names = [n.strip() for n in args.tune.split(",") if n.strip()]
    check_timing(names, base.gait, args.duration, args.warmup)
    if args.range and not args.robust:
        raise ValueError("--range narrows the variations of --robust N: give --robust too")
    if args.keep_base and not args.robust:
        raise ValueError(
            "--keep-base keeps the base's passes in --robust N's worlds: give --robust"
        )
    ranges = ranges_from(args.range, args.duration)
    backend = backend_of(args)
    local = (
        None if args.cluster is not None else evaluator_for(robot, threads=args.threads, **backend)
    )
    tuner = Tuner(
        base,
        names,
        evaluator=local,
        duration_s=args.duration,
        warmup_s=args.warmup,
        popsize=args.popsize,
        sigma0=args.sigma,
        seed=args.seed,
        weights=LossWeights(
            band=args.band_weight,
            steering=args.steering_weight,
            cross_talk=args.cross_talk_weight,
            speed_scale=speed_scale_of(robot.geometry),
            torque=args.torque_weight,
        ),
        cases=[c.strip() for c in args.cases.split(",") if c.strip()] if args.cases else None,
        robust=args.robust,
        robust_weight=args.robust_weight,
        ranges=ranges,
        keep_base=args.keep_base,
    )
    tuner.settings["set"] = args.set
    settings = {**tuner.settings, "robot": robot.name}
    args.study_name = args.study_name or study_name_for(robot.name, settings)
    with contextlib.ExitStack() as stack:
        events = EventWriter(events_to or events_out(args.events, stack), f"--events {args.events}")
        try:
            chosen, selected = search(args, robot, tuner, local, settings, events)
        except KeyboardInterrupt:
            print(
                f"artro tune: interrupted; the study {args.study} keeps every candidate that "
                "finished: the same command resumes it",
                file=sys.stderr,
            )
            return 130
        report(args, robot.name, name, start_mode, tuner, chosen, selected, events)
    return 0


def events_out(spec: str | None, stack: contextlib.ExitStack) -> Any:
    """Where `--events` goes: None, standard output, or a file (made, line-buffered)."""
    if spec is None:
        return None
    if spec == "-":
        return sys.stdout
    path = Path(spec)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        handle = path.open("w", encoding="utf-8", buffering=1)
    except OSError as exc:
        raise OSError(f"cannot write --events {spec}: {exc.strerror or exc}") from exc
    stack.callback(_close_quietly, handle)  # a write that failed has been said already
    return handle


def _close_quietly(handle: TextIO) -> None:
    with contextlib.suppress(OSError):
        handle.close()


def search(
    args: argparse.Namespace,
    robot: RobotModel,
    tuner: Tuner,
    local: Any,
    settings: dict[str, Any],
    events: EventWriter,
) -> tuple[tuple[float, Any, dict[str, Any]], str]:
    """Run the study (its store opened first: a second writer is refused before a cluster is
    reached) and pick the candidate `--select` names: (it, how it was chosen: the `--select`,
    or "lowest loss" where no candidate met it)."""
    with StudyStore(args.study, settings, name=args.study_name) as store:
        events(START, robot=robot.name, base=tuner.base.name, study=str(args.study),
               study_name=args.study_name, generations=args.generations,
               popsize=args.popsize, budget=args.generations * args.popsize,
               runs=len(tuner.runs), duration_s=args.duration)  # fmt: skip
        if local is not None:
            tuner.run(args.generations, store, sys.stderr, events=events)
        else:
            tuner.evaluator = evaluator_for(robot, **cluster_of(args))
            try:
                tuner.run(args.generations, store, sys.stderr, events=events)
            finally:
                close_evaluator(tuner.evaluator)
    chosen, selected = tuner.best, args.select
    if args.select == "walking":
        chosen = best_walking(tuner)
        if chosen is None:
            print("no candidate walked every run without a fall; saving the lowest loss instead")
            chosen, selected = tuner.best, "lowest loss"
    elif args.select in ("passing", "steering"):
        chosen = best_passing(tuner, by="loss" if args.select == "passing" else "steering")
        if chosen is None:
            print("no candidate met every criterion; saving the lowest loss instead")
            chosen, selected = tuner.best, "lowest loss"
    assert chosen is not None
    return chosen, selected


def report(
    args: argparse.Namespace,
    robot: str,
    name: str,
    start_mode: bool,
    tuner: Tuner,
    chosen: tuple[float, Any, dict[str, Any]],
    selected: str,
    events: EventWriter,
) -> None:
    """Save the chosen set (among the presets without `--base`, to `--out`) and say what it
    did: printed, and as the RESULT event."""
    result = stamped(ParameterSet(robot=robot, gait=chosen[1]), name)
    saved, earlier = [], ""
    if start_mode:
        store = PresetStore(default_data_dir(), builtin_presets())
        try:  # the robot's last tune: replaced, and said so (the dashboard's tune saves it too)
            earlier = f" (replacing the one of {store.get(name).created or 'earlier'})"
        except (PresetNotFound, PresetError):
            earlier = ""
        store.save(name, result)
        saved.append(f"preset {name!r} in {store.directory}{earlier}")
    out_spec = args.out if args.out is not None else (None if start_mode else DEFAULT_OUT)
    if out_spec is not None:
        out = Path(out_spec.replace("NAME", name) if out_spec == DEFAULT_OUT else out_spec)
        out.parent.mkdir(parents=True, exist_ok=True)
        write_parameter_set(out, result)
        saved.append(f"{out} as {name!r}")
    print(
        f"loss {chosen[0]:.4f} ({selected}) after {tuner.generation} generations; "
        f"saved {' and '.join(saved)}"
    )
    figures = result_figures(chosen[2], tuner.weights.speed_scale)
    events(RESULT, name=name, preset=start_mode, loss=chosen[0], select=args.select,
           walked=walks(chosen[2]), generations=tuner.generation, trials=len(tuner.evaluated),
           saved=saved, replaced=bool(start_mode and earlier), figures=figures,
           **({"families": fam} if (fam := families_of(tuner, chosen)) else {}))  # fmt: skip
    if varied := varied_summary(tuner, chosen):
        print(f"  robust: {varied}")
    if fell := [run for run, m in chosen[2].items() if m.get("fell", True)]:
        where = args.robot or robot
        select = "" if args.select == "walking" else ", or --select walking,"
        instead = (
            f"stronger servos first: artro robot check {where} --suggest"
            if args.short_servos
            else f"more --generations{select} may find one that walks them all; artro bench "
            f"robust --robot {where} names the servos at their limit"
        )
        print(f"  note: the saved set falls in {len(fell)} of {len(chosen[2])} runs "
              f"({', '.join(fell)}): {instead}")  # fmt: skip
    for row in figures:  # the judged runs: each case against its target, each CA pair
        mark = "" if row["fell"] else ("  ok" if row["passes"] else "  off")
        if "target" in row:
            unit = row.get("unit", "")
            shown = "fell" if row["fell"] else f"{row['value']:+.2f} {unit}"
            print(f"  {row['run']:24s} target {row['target']:+6.2f} {unit:5s}  tuned {shown}{mark}")
        else:
            shown = "fell" if row["fell"] else f"gain {row['gain']:.2f}, bend {row['bend']:+.2f}"
            print(f"  {row['run']:24s} eq (13): gain 1, bend 0;  tuned {shown}{mark}")
    if any("target" in row for row in figures):
        print(f"  (ok: within {SPEED_TOLERANCE:.0%} of the target, the spot's drift under "
              f"{SPOT_DRIFT_LIMIT_CM_S:g} cm/s scaled to the legs, eq (13)'s gain within "
              f"{STEERING_TOLERANCE:.0%}; artro bench paper judges 60 s runs)")  # fmt: skip
    if start_mode:  # what to do with it
        where = args.robot or robot
        print(f"next: artro run --robot {where} --params {name} --motion a_p=0.07; artro serve "
              f"--robot {where} --params {name} (a robot of your own starts in its newest tune "
              f"without --params); artro bench robust --robot {where} --presets {name} (does it "
              "walk off the model too?)")  # fmt: skip
