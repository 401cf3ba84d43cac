"""`artro robot import`: a URDF or MJCF biped mapped onto the gait by its geometry, its
description written and its mapping printed (docs/DESIGN.md §16, docs/CAD.md)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any, TextIO

from app.cli.options import action, output_file
from app.robots.cad_import import import_robot, mapping_rows, write_import
from app.robots.description import RobotDescription
from app.robots.model import RobotModel

FRONT_FROM = {"toes": "its toes", "knees": "its knees", "given": "--forward"}


def add_import_action(sub: Any) -> None:
    """The `import` action of `artro robot`, with its options."""
    imp = action(
        sub,
        "import",
        "map a URDF or MJCF biped onto the gait by its geometry and write its description",
        """examples:
  artro robot import op3.xml -o op3.yaml            then: artro robot show op3.yaml
  artro robot import robot.urdf --package-dir ~/ws/src --servo DS3218 -o mine.yaml
  artro robot import op3.xml --keep-actuators -o op3.yaml   the file's own servos
exit status 2, in one sentence naming the joint, for a file the gait cannot drive""",
    )
    imp.add_argument("file", metavar="FILE", help="a .urdf or an MJCF .xml")
    imp.add_argument(
        "-o", "--output", type=output_file, metavar="DESC.yaml", help="(default: NAME.yaml)"
    )
    imp.add_argument("--name", help="the robot's name (default: from the file's name)")
    imp.add_argument("--servo", default="MG996R", help="every leg joint's servo (default: MG996R)")
    imp.add_argument(
        "--keep-actuators",
        action="store_true",
        help="keep the file's position actuators (gains, force limits) and joint settings",
    )
    imp.add_argument(
        "--package-dir",
        action="append",
        default=[],
        metavar="DIR",
        help="where package:// mesh paths resolve (repeatable; default: beside the file)",
    )
    imp.add_argument(
        "--imu-site",
        metavar="NAME",
        help="a site of the file for the IMU (default: the trunk's origin, its axes the trunk's)",
    )
    imp.add_argument(
        "--forward",
        choices=("+x", "-x", "+y", "-y", "+z", "-z"),
        help="the axis of the file's root frame the toes point along, for a robot whose soles "
        "are centred under its ankles and whose knees have no range (default: from the "
        "geometry)",
    )


def print_mapping(desc: RobotDescription, out: TextIO) -> None:
    """An imported robot's mapping: each gait joint's joint in the file, sign, zero, axis error."""
    if desc.cad is None:
        return
    print(
        f"  imported from {desc.cad.file} (its front told by {FRONT_FROM[desc.cad.forward_from]})",
        file=out,
    )
    print("  gait joint      file joint                sign  zero rad  axis error", file=out)
    for row in mapping_rows(desc):
        print(
            f"  {row['joint']:15s} {row['file_joint']:25s} {row['sign']:+4d} "
            f"{row['zero_rad']:+9.4f} {row['axis_error_deg']:9.2f}°",
            file=out,
        )
    if desc.cad.held:
        print(f"  held rigid (no leg's): {', '.join(desc.cad.held)}", file=out)


def import_command(args: argparse.Namespace, out: TextIO) -> int:
    """`artro robot import`: map the file, write the description, print the mapping."""
    source = Path(args.file)
    target = Path(args.output) if args.output else None
    imported = import_robot(
        source,
        output=target or Path.cwd() / "imported.yaml",
        name=args.name,
        servo=args.servo,
        keep_actuators=args.keep_actuators,
        package_dirs=tuple(args.package_dir),
        imu_site=args.imu_site,
        forward=args.forward,
    )
    desc = imported.description
    if target is None:
        target = Path(f"{desc.name}.yaml")
        if target.exists():
            raise ValueError(
                f"{target} exists: give -o {target} to write over it, or -o another file"
            )
    write_import(imported, target, f"artro robot import {args.file}")
    robot = RobotModel.load(target)
    print(
        f"{desc.name}: {robot.total_mass_kg():.3f} kg, legs {desc.geometry.thigh_m:.4f} + "
        f"{desc.geometry.shank_m:.4f} m, hips {desc.geometry.hip_spacing_m:.4f} m apart",
        file=out,
    )
    print_mapping(robot.description, out)
    for note in imported.notes:
        print(f"  note: {note}", file=out)
    print(f"wrote {target}; next: artro robot show {target}, artro tune --robot {target}", file=out)
    return 0
