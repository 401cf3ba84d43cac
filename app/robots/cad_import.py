"""`artro robot import`: a URDF or MJCF biped read by MuJoCo, mapped onto the gait by geometry
(`app.robots.cad_mapping`) and written as a robot description with a `cad:` section that every
command takes (docs/DESIGN.md §16). The import refuses, in one sentence naming the joint, what
the gait cannot drive; it never guesses."""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from app.robots.cad_builder import CadFileError, read_file_spec, robot_root, strip_scene
from app.robots.cad_mapping import ImportRefused, Mapping, map_model
from app.robots.cad_source import resolved
from app.robots.description import RobotDescription
from app.robots.description_parts import LEG_JOINTS
from app.robots.library import RobotError, parse_description
from app.robots.servos import servo_table

DEFAULT_SERVO = "MG996R"
FORWARD_AXES = ("+x", "-x", "+y", "-y", "+z", "-z")
#: the TDM-PWM wiring an imported robot gets: the built-in ArtRo's
DEFAULT_TDM = {
    "OC1A": [f"l_{j}" for j in LEG_JOINTS[:5]],
    "OC1B": [f"r_{j}" for j in LEG_JOINTS[:5]],
    "OC1C": ["l_ankle_roll"],
    "OC3A": ["r_ankle_roll"],
}


@dataclass(frozen=True)
class Imported:
    """The description, the mapping it came from and what the import says of it."""

    description: RobotDescription
    document: dict[str, Any]
    mapping: Mapping
    notes: list[str]


def import_robot(
    path: Path,
    *,
    output: Path,
    name: str | None = None,
    servo: str = DEFAULT_SERVO,
    keep_actuators: bool = False,
    package_dirs: tuple[str, ...] = (),
    imu_site: str | None = None,
    forward: str | None = None,
) -> Imported:
    """Map the file at `path` and make its description (its `cad.file` relative to `output`'s
    folder; `forward`: the root frame's axis the toes point along, where the geometry cannot
    tell); ImportRefused / CadFileError / RobotError (ValueErrors) with the reason."""
    if not path.is_file():
        raise CadFileError(f"no file {str(path)!r}")
    kind = "urdf" if path.suffix.lower() == ".urdf" else "mjcf"
    spec = read_file_spec(path, package_dirs)
    root = robot_root(spec)
    if imu_site is not None and spec.site(imu_site) is None:
        raise CadFileError(f"{path}: no site {imu_site!r} for --imu-site")
    strip_scene(spec, root, constraints=False)  # a closed chain is refused, not dropped
    try:
        model = spec.compile()
    except ValueError as err:
        raise CadFileError(
            f"{path}: MuJoCo cannot compile it: {' '.join(str(err).split())}"
        ) from None
    if forward is not None and forward not in FORWARD_AXES:
        raise CadFileError(f"--forward {forward!r}: give one of {', '.join(FORWARD_AXES)}")
    mapping = map_model(model, model.body(root.name).id, forward)
    table = servo_table()
    if servo not in table:
        raise RobotError(f"--servo: unknown servo {servo!r}; known: {', '.join(sorted(table))}")
    spec_of_servo = table[servo]
    notes: list[str] = []
    document = _document(
        path,
        output,
        kind,
        mapping,
        name or name_of(path),
        servo,
        keep_actuators,
        package_dirs,
        imu_site,
        notes,
    )
    description = parse_description(document, f"the import of {path}")
    description = description.model_copy(  # as a description read from `output` would be
        update={"cad": resolved(description.cad, output.resolve().parent)}
    )
    if spec_of_servo.signal != "pwm":
        notes.append(
            f"{servo} is a bus servo: the simulation sends its goals as a sync write per frame "
            "(4096 steps a turn, at 1 Mbit/s) and moves it by its figures; the ATmega128 "
            "firmware, which sends pulses, is not built for it"
        )
    return Imported(description, document, mapping, notes)


def name_of(path: Path) -> str:
    """A robot's name made from a file's: lower case letters, digits, '-' and '_', at most 40."""
    name = re.sub(r"[^a-z0-9_-]+", "-", path.stem.lower()).strip("-_") or "imported"
    return (name if name[0].isalpha() else f"r-{name}")[:40].rstrip("-_")


def _document(
    path: Path,
    output: Path,
    kind: str,
    mapping: Mapping,
    name: str,
    servo: str,
    keep_actuators: bool,
    package_dirs: tuple[str, ...],
    imu_site: str | None,
    notes: list[str],
) -> dict[str, Any]:
    spec = servo_table()[servo]
    travel = min(math.radians(spec.travel_deg) / 2, math.pi / 2)
    joints = {}
    for gait, j in mapping.joints.items():
        lo, hi = j.range_rad if j.range_rad is not None else (-travel, travel)
        clipped = (max(lo, -travel), min(hi, travel))
        if abs(clipped[0] - lo) > 1e-3 or abs(clipped[1] - hi) > 1e-3:
            notes.append(
                f"{gait} ({j.file_joint}): range {lo:.3f}..{hi:.3f} rad held to the {servo}'s "
                f"travel, {clipped[0]:.3f}..{clipped[1]:.3f} rad"
            )
        joints[gait] = {"range_rad": [round(clipped[0], 5), round(clipped[1], 5)]}
    masses = mapping.link_masses_kg
    links = {
        link: [{"name": "from the file", "mass_kg": round(masses[link], 6)}]
        for link in ("hip_yaw", "hip_roll", "thigh", "shank", "ankle", "foot")
    }
    relative = os.path.relpath(path.resolve(), output.resolve().parent)
    return {
        "schema_version": 1,
        "name": name,
        "title": f"imported from {path.name}",
        "default_preset": "paper",
        "supply_voltage_v": spec.voltages_v[len(spec.voltages_v) // 2],  # the middle rating
        "servo": servo,
        "geometry": {k: round(v, 6) for k, v in mapping.geometry.items()},
        "trunk": [
            {"name": "the file's trunk and what is held", "mass_kg": round(masses["trunk"], 6)}
        ],
        "links": links,
        "servo_mounts": {},
        "joints": joints,
        "tdm_channels": DEFAULT_TDM,
        "cad": {
            "file": relative,
            "format": kind,
            "package_dirs": [str(Path(d).resolve()) for d in package_dirs],
            "root_body": mapping.root_body,
            "trunk_quat": [round(q, 9) for q in mapping.trunk_quat],
            "forward_from": mapping.forward_from,
            "joints": {
                gait: {
                    "file_joint": j.file_joint,
                    "sign": j.sign,
                    "zero_rad": round(j.zero_rad, 6) + 0.0,
                    "axis_error_deg": round(j.axis_error_deg, 3),
                }
                for gait, j in mapping.joints.items()
            },
            "feet": {
                side: {
                    "body": f.body,
                    "sole_pos_m": [round(x, 6) for x in f.sole_pos_m],
                    "sole_quat": [round(q, 9) for q in f.sole_quat],
                    "plate_geom": f.plate_geom,
                }
                for side, f in mapping.feet.items()
            },
            "sites": {
                n: {"body": b, "pos_m": [round(x, 6) for x in p]}
                for n, (b, p) in mapping.sites.items()
            },
            "held": list(mapping.held),
            "keep_actuators": keep_actuators,
            "imu_site": imu_site,
        },
    }


def write_import(imported: Imported, target: Path, command: str) -> None:
    """The imported description as YAML at `target`, with a header saying where it came from."""
    header = (
        f"{imported.description.name}: written by `{command}`; the model is the file's,\n"
        "mapped onto the gait by its geometry (`artro robot show` prints the mapping)"
    )
    text = "".join(f"# {line}\n" for line in header.splitlines())
    target.write_text(text + yaml.safe_dump(imported.document, sort_keys=False), encoding="utf-8")


def mapping_rows(description: RobotDescription) -> list[dict[str, Any]]:
    """The mapping table of an imported robot: gait joint, file joint, sign, zero, axis error."""
    cad = description.cad
    if cad is None:
        return []
    return [
        {
            "joint": gait,
            "file_joint": j.file_joint,
            "sign": j.sign,
            "zero_rad": j.zero_rad,
            "axis_error_deg": j.axis_error_deg,
        }
        for gait, j in cad.joints.items()
    ]


__all__ = [
    "CadFileError",
    "ImportRefused",
    "Imported",
    "import_robot",
    "mapping_rows",
    "name_of",
    "write_import",
]
