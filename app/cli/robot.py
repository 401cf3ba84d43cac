"""`artro robot list|show|check|export-mjcf|export-urdf|import`: the built-in robots, a
description with the figures that follow from it (eq (1) per joint, an imported robot's
mapping), its checks, its model as MJCF or URDF, a URDF or MJCF biped imported (docs/DESIGN.md
§7, §16)."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any, TextIO

from app.cli.options import action, output_file, output_file_of, subcommand
from app.cli.robot_import import add_import_action, import_command, print_mapping
from app.robots import builtin_robot_names, load_description, model_xml
from app.robots.checks import JointTorque, eq1_torques, lighter_parts, robot_warnings
from app.robots.description import RobotDescription
from app.robots.model import RobotModel
from app.robots.swap import (
    derived,
    derived_name,
    lightest_servo,
    suggest_servos,
    write_description,
)
from app.robots.urdf_export import model_urdf

EXAMPLES = """examples:
  artro robot list
  artro robot show micro --json
  cp models/robots/artro.yaml my.yaml   then in it name: my, and your lengths, masses, servos
  artro robot check my.yaml            then: artro serve --robot my.yaml
  artro robot check my.yaml --suggest -o my-servos.yaml   the lightest servos that carry it
  artro robot export-mjcf artro -o artro.xml
  artro robot export-urdf artro -o artro.urdf
  artro robot import my_biped.urdf -o my.yaml   your CAD export, mapped by its geometry"""


def add_parser(sub: Any) -> None:
    robot = subcommand(
        sub, "robot", "list, show, check and export robot descriptions", command, EXAMPLES
    )
    sub = robot.add_subparsers(dest="robot_command", required=True, metavar="ACTION")
    action(sub, "list", "the built-in robots", "examples:\n  artro robot list")
    show = action(
        sub,
        "show",
        "a description and the figures that follow from it",
        """examples:
  artro robot show artro               mass, heights, servos, eq (1) per joint
  artro robot show my.yaml --json      the same as one JSON object
  artro robot show my.yaml --png my.png   drawn, with each joint's axis and name""",
    )
    show.add_argument("robot", metavar="NAME|FILE")
    show.add_argument("--json", action="store_true", help="print one JSON object")
    show.add_argument(
        "--png",
        type=output_file,
        metavar="FILE",
        help="also draw the robot with each leg joint's axis and name (an import's mapping; "
        "default: no drawing)",
    )
    check = action(
        sub,
        "check",
        "validate a description; exit 2 naming every bad field (then the checks across fields)",
        """examples:
  artro robot check my.yaml            every error, or: valid, with eq (1)'s least margin
  artro robot check my.yaml --suggest  write my-suggested.yaml with servos that carry it
  artro robot check my.yaml --suggest -o my-servos.yaml""",
    )
    check.add_argument("robot", metavar="NAME|FILE")
    check.add_argument(
        "--suggest",
        action="store_true",
        help="write the description with the lightest servo of the table that carries each "
        "joint eq (1) finds short (masses follow the servos)",
    )
    check.add_argument(
        "-o",
        "--output",
        type=output_file_of((".yaml", ".yml"), "a YAML description"),
        metavar="FILE",
        help="with --suggest (default: NAME-suggested.yaml)",
    )
    for kind, what, example in (
        (
            "mjcf",
            "write the generated MuJoCo model as MJCF",
            """examples:
  artro robot export-mjcf artro -o artro.xml    then: python -m mujoco.viewer --mjcf artro.xml
  artro robot export-mjcf my.yaml | less""",
        ),
        (
            "urdf",
            "write the robot as URDF (links with their masses, revolute joints, collision shapes)",
            """examples:
  artro robot export-urdf artro -o artro.urdf   then: artro robot import artro.urdf""",
        ),
    ):
        export = action(sub, f"export-{kind}", what, example)
        export.add_argument("robot", metavar="NAME|FILE")
        export.add_argument(
            "-o", "--output", type=output_file, metavar="FILE", help="default: standard output"
        )
    add_import_action(sub)


def command(args: argparse.Namespace, out: TextIO | None = None) -> int:
    out = out or sys.stdout
    if args.robot_command == "list":
        for name in builtin_robot_names():
            desc = load_description(name)
            print(f"{name:12s} {desc.title}", file=out)
        return 0
    if args.robot_command == "check" and args.output and not args.suggest:
        raise ValueError("-o FILE goes with --suggest")
    if args.robot_command == "import":
        return import_command(args, out)
    desc = load_description(args.robot)  # RobotError (a ValueError) names every bad field
    if args.robot_command == "check":
        robot = RobotModel.load(desc)  # compiles
        torques = eq1_torques(desc)  # once: the warnings and the advice
        warnings = robot_warnings(desc, torques=torques)
        print(
            f"{as_written(args.robot, desc.name)}: valid; {robot.total_mass_kg():.3f} kg, legs "
            f"{desc.geometry.thigh_m:g} + {desc.geometry.shank_m:g} m",
            file=out,
        )
        least = min(torques, key=lambda t: t.margin)
        gaits = " and ".join(name for name, _ in desc.walked_gaits())
        print(
            f"eq (1) at the poses of {gaits}: the least margin {least.margin:+.0%} "
            f"({least.joint}); a walk asks more at its peaks (artro run, and the dashboard's "
            "servo load budget, measure them)",
            file=out,
        )
        for w in warnings:
            print(f"warning: {w}", file=out)
        for line in servo_advice(desc, torques):
            print(f"  advice: {line}", file=out)
        if args.suggest:
            return suggest(desc, args.output, out, source=args.robot, torques=torques)
        return 0
    if args.robot_command in ("export-mjcf", "export-urdf"):
        text = model_xml(desc) if args.robot_command == "export-mjcf" else model_urdf(desc)
        if args.output:
            not_the_source(Path(args.output), args.robot, f"-o {args.output}", "e.g. -o my.xml")
            Path(args.output).write_text(text, encoding="utf-8")
        else:
            out.write(text)
        return 0
    model = RobotModel.load(desc)
    summary = model.summary()
    if args.png:
        from app.study.robot_picture import draw_robot  # matplotlib: only to draw

        draw_robot(model, Path(args.png))
        print(f"drew {args.png}", file=sys.stderr if args.json else out)
    if args.json:
        print(json.dumps(summary, allow_nan=False), file=out)
        return 0
    d = summary["derived"]
    print(f"{desc.name}: {desc.title}", file=out)
    print(
        f"  {d['total_mass_kg']:.3f} kg, thigh {desc.geometry.thigh_m} m, shank "
        f"{desc.geometry.shank_m} m, standing {d['standing_height_m']:.3f} m, supply "
        f"{desc.supply_voltage_v:g} V, default preset {desc.default_preset!r}",
        file=out,
    )
    print(
        "  joint           servo    stall N·m  kp N·m/rad  damping  eq (1) need  margin", file=out
    )
    for t in d["eq1"]:
        s = d["servos"][t["joint"]]
        print(
            f"  {t['joint']:15s} {t['servo']:8s} {s['stall_torque_nm']:9.3f} "
            f"{s['kp_nm_rad']:11.3f} {s['damping_nm_s_rad']:8.4f} {t['required_nm']:12.3f} "
            f"{t['margin']:+7.0%}",
            file=out,
        )
    for w in d["warnings"]:
        print(f"warning: {w}", file=out)
    print_mapping(desc, out)
    return 0


def as_written(given: str, name: str) -> str:
    """The robot as the user named it: its name, or the file given and the name in it where
    they differ (`other.yaml (robot my)`)."""
    return name if given == name or Path(given).stem == name else f"{given} (robot {name})"


def servo_advice(desc: RobotDescription, torques: Sequence[JointTorque]) -> list[str]:
    """Per joint that eq (1) finds short (`torques`: `eq1_torques(desc)`): the lightest servo of
    the table or the file that carries it."""
    lines = []
    for t in torques:
        if t.margin >= 0:
            continue
        choice = lightest_servo(t.required_nm, desc.supply_voltage_v, servos=desc.servo_catalogue())
        lines.append(
            f"{t.joint}: the lightest servo that carries {t.required_nm:.3f} N·m at "
            f"{desc.supply_voltage_v:g} V is the {choice.name} ({choice.stall_torque_nm:.3f} N·m, "
            f"{1000 * choice.mass_kg:.0f} g)"
            if choice
            else f"{t.joint}: no servo of the table or the file carries {t.required_nm:.3f} N·m at "
            f"{desc.supply_voltage_v:g} V (models/servos.yaml)"
        )
    return lines


def copied_trunk(desc: RobotDescription) -> str | None:
    """The built-in robot whose trunk `desc` carries part for part (a copied file's), if any
    but itself."""
    for name in builtin_robot_names():
        if name != desc.name and load_description(name).trunk == desc.trunk:
            return name
    return None


def lighter_lines(desc: RobotDescription, torques: Sequence[JointTorque]) -> list[str]:
    """The other way to carry a robot whose servos are short (`torques`: its eq (1)): how light
    it would have to be to keep them, and whose trunk it carries where it is a built-in
    robot's, copied."""
    short = [t for t in torques if t.margin < 0]
    if not short:
        return []
    servos = ", ".join(dict.fromkeys(t.servo for t in short))
    trunk = sum(p.mass_kg for p in desc.trunk)
    lines = []
    if copied := copied_trunk(desc):
        parts = ", ".join(f"{p.name} {p.mass_kg:.3f} kg" for p in desc.trunk if p.mass_kg)
        lines.append(f"  its trunk is {copied}'s, as copied: {trunk:.3f} kg ({parts})")
    found = lighter_parts(desc, torques)
    if found is None:
        lines.append(
            f"  no lighter robot keeps its {servos}: with its parts but the servos at a "
            "thousandth of their mass eq (1) still fails (shorter legs or stronger servos)"
        )
        return lines
    scaled = "trunk's" if found.parts == "trunk" else "trunk's and links' (both legs)"
    now = f"{found.now_kg:.3f} kg"
    if found.parts != "trunk":
        now += f": trunk {trunk:.3f} kg, links {found.now_kg - trunk:.3f} kg"
    lines.append(
        f"  or keep its {servos}: eq (1) holds on every joint with its {scaled} parts at "
        f"{found.most_kg:.3f} kg or less (now {now}), the robot {found.robot_kg:.3f} kg "
        f"instead of {desc.parts_mass_kg():.3f} kg"
    )
    return lines


UNCARRIED = (
    "eq (1) still fails there (exit status 1): a lighter robot, shorter legs, or a stronger "
    "servo of your own in the file's `servos` would carry it"
)


def not_the_source(target: Path, source: str, what: str, instead: str) -> None:
    """ValueError if `target` is the description file `source` (also through a link): writing
    it would lose its comments and layout."""
    if source and Path(source).exists() and target.exists() and target.samefile(source):
        raise ValueError(
            f"{what} is the description read ({source}): writing it would lose the "
            f"description; give another file, {instead}"
        )


def earlier_description(target: Path) -> str:
    """How the line that names the file written says what it replaced ("" for nothing there);
    ValueError for a file there that is not a robot description (it would be lost)."""
    if not target.exists():
        return ""
    try:
        earlier = load_description(str(target))
    except ValueError:
        raise ValueError(
            f"-o {target}: that file exists and is not a robot description; writing would "
            "lose it: give another file, or remove it first"
        ) from None
    return f", replacing the robot {earlier.name!r} there"


def suggest(
    desc: RobotDescription,
    output: str | None,
    out: TextIO,
    source: str = "",
    torques: Sequence[JointTorque] | None = None,
) -> int:
    """`robot check --suggest`: the description with the servos that carry it, written (never
    over `source`, the file it was read from: its comments would be lost); with no servo to
    change, written only where `output` asks (the next command reads it). Exit status 1 when
    some joint no servo carries (eq (1) still fails), else 0."""
    target = Path(output or f"{derived_name(desc.name, 'suggested')}.yaml")
    not_the_source(
        target, source, f"-o {output}", f"e.g. -o {derived_name(desc.name, 'suggested')}.yaml"
    )
    if output is None and target.exists():
        raise ValueError(f"{target} exists: give -o {target} to write over it, or -o another file")
    replacing = earlier_description(target)
    found = suggest_servos(desc, lambda r: {t.joint: t.required_nm for t in eq1_torques(r)})
    lighter = lighter_lines(desc, eq1_torques(desc) if torques is None else torques)
    if not found.swaps:
        left = f"; none carries {', '.join(found.uncarried)}" if found.uncarried else ""
        if output is None:
            print(f"no servo to change{left}: nothing written", file=out)
            for line in lighter:
                print(line, file=out)
            if found.uncarried:
                print(UNCARRIED, file=out)
            return 1 if found.uncarried else 0
        print(f"no servo to change{left}: -o {output} gets the robot as it is", file=out)
    servos = "with the lightest servos that carry it" if found.swaps else "with its own servos"
    robot = found.robot if found.swaps else derived(desc, derived_name(desc.name, "suggested"))
    header = (
        f"{robot.name}: written by `artro robot check {source or desc.name} --suggest`,\n"
        f"the robot {desc.name} {servos} (eq (1)); what is left\n"
        "at its default is left out, and the comments stay in the file it was read from"
    )
    path = write_description(robot, target, header)
    for joint, old, new, need in found.swaps:
        print(f"  {joint}: {old} -> {new} (eq (1) asks {need:.3f} N·m)", file=out)
    if found.uncarried:
        print(f"  no servo of the table or the file carries {', '.join(found.uncarried)}", file=out)
    for line in lighter:
        print(line, file=out)
    mass = robot.parts_mass_kg()
    print(
        f"wrote {path} ({mass:.3f} kg{replacing}); next: artro robot check {path}, then "
        f"artro tune --robot {path}",
        file=out,
    )
    if found.uncarried:
        print(UNCARRIED, file=out)
    return 1 if found.uncarried else 0
