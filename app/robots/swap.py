"""Other servos on some joints (docs/DESIGN.md §7): the servo of the table (and of the robot's
file) that carries a torque with eq (1)'s safety factor, and the robot with it swapped in -- its
description with those joints' servo changed and a stated total mass moved by the servos' mass
difference, so the masses still add up and the model carries the new servos' mass, torque, speed."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import yaml

from app.robots.description import RobotDescription
from app.robots.servos import ServoSpec, rating_at, servo_table
from gait import JOINT_NAMES


@dataclass(frozen=True)
class ServoChoice:
    name: str
    stall_torque_nm: float  # at the robot's supply voltage
    mass_kg: float


Servos = Mapping[str, ServoSpec] | None  # None: the table; a robot's servo_catalogue() adds its own


def servo_choices(
    voltage_v: float, signal: str = "pwm", *, servos: Servos = None
) -> list[ServoChoice]:
    """The servos of `signal` rated at `voltage_v` (of `servos`, default the table), weakest
    first."""
    out = []
    for name, spec in (servo_table() if servos is None else servos).items():
        if spec.signal != signal:
            continue
        try:
            stall, _speed, _interpolated = rating_at(spec, voltage_v, name)
        except ValueError:  # not rated at this supply
            continue
        out.append(ServoChoice(name, stall, spec.mass_kg))
    return sorted(out, key=lambda c: (c.stall_torque_nm, c.mass_kg))


def smallest_servo(
    need_nm: float, voltage_v: float, signal: str = "pwm", *, servos: Servos = None
) -> ServoChoice | None:
    """The weakest servo (of `servos`, default the table) whose stall torque at `voltage_v` is
    at least `need_nm` (None: none is that strong)."""
    choices = servo_choices(voltage_v, signal, servos=servos)
    return next((c for c in choices if c.stall_torque_nm >= need_nm), None)


def lightest_servo(
    need_nm: float, voltage_v: float, signal: str = "pwm", *, servos: Servos = None
) -> ServoChoice | None:
    """The lightest servo (of `servos`, default the table; pass a robot's `servo_catalogue()`
    for its own too) whose stall torque at `voltage_v` is at least `need_nm` (None: none is that
    strong): what a builder would fit."""
    choices = servo_choices(voltage_v, signal, servos=servos)
    able = [c for c in choices if c.stall_torque_nm >= need_nm]
    return min(able, key=lambda c: (c.mass_kg, c.stall_torque_nm), default=None)


@dataclass(frozen=True)
class Suggestion:
    """`suggest_servos`' answer: the robot with the servos swapped, each swap (joint, old servo,
    new servo, eq (1) need N·m), and the joints no servo of the table carries."""

    robot: RobotDescription
    swaps: tuple[tuple[str, str, str, float], ...]
    uncarried: tuple[str, ...]


def mirror(joint: str) -> str:
    """The joint's twin on the other leg: l_knee <-> r_knee."""
    side, rest = joint.split("_", 1)
    return f"{'r' if side == 'l' else 'l'}_{rest}"


def suggest_servos(
    desc: RobotDescription, required_nm: Callable[[RobotDescription], dict[str, float]]
) -> Suggestion:
    """`desc` with the lightest servo that carries its eq (1) need on each joint whose servo is
    too weak, and on its mirror joint where both legs had the same servo (the larger need of
    the two: a robot built alike on both sides stays so, though one pose loads one side more);
    `required_nm(robot)` gives each joint's need (1 + sf times its load). A heavier
    servo adds load below it, so the needs are taken again after each round (at most
    len(JOINT_NAMES) rounds: a joint only ever gets a stronger servo)."""
    table, swaps, uncarried = desc.servo_catalogue(), [], set()
    robot = desc
    for _ in range(len(JOINT_NAMES)):
        need = required_nm(robot)
        short = {
            j: n for j, n in need.items()
            if n > rating_at(table[robot.joint_servo(j)], robot.supply_voltage_v, j)[0]
        }  # fmt: skip
        for joint, n in list(short.items()):  # the mirror joint too: a biped is built alike
            twin = mirror(joint)
            if twin not in short and robot.joint_servo(twin) == robot.joint_servo(joint):
                short[twin] = max(n, need[twin])
        for joint in short:  # a pair takes the servo that carries the larger need of the two
            short[joint] = max(short[joint], short.get(mirror(joint), 0.0))
        changed = False
        for joint, n in short.items():
            choice = lightest_servo(n, robot.supply_voltage_v, servos=table)
            if choice is None:
                uncarried.add(joint)
                continue
            swaps.append((joint, robot.joint_servo(joint), choice.name, n))
            robot = with_servo(robot, [joint], choice.name)
            uncarried.discard(joint)
            changed = True
        if not changed:
            break
    final: dict[str, tuple[str, str, str, float]] = {}
    for joint, old, new, n in swaps:  # a joint swapped twice: from its first servo to its last
        first = final.get(joint, (joint, old, new, n))[1]
        final[joint] = (joint, first, new, n)
    title = f"{desc.title}; servos suggested by eq (1)"
    return Suggestion(
        derived(robot, derived_name(desc.name, "suggested"), title) if final else desc,
        tuple(final.values()),
        tuple(sorted(uncarried)),
    )


def derived(desc: RobotDescription, name: str, title: str | None = None) -> RobotDescription:
    """`desc` as a robot of its own: named `name` (its presets and studies are not `desc`'s),
    titled `title` (to a title's 200 characters) where given."""
    data = dict(desc.model_dump(mode="json"), name=name)
    if title is not None:
        data["title"] = title[:200]
    return RobotDescription.model_validate(data)


def derived_name(name: str, tag: str) -> str:
    """`name-tag`, within a name's 40 characters: `name` shortened, never the tag, so the new
    robot's name (its presets, its studies) is never the old one's."""
    return f"{name[: 40 - len(tag) - 1]}-{tag}"


def with_servo(desc: RobotDescription, joints: Sequence[str], servo: str) -> RobotDescription:
    """`desc` with `servo` (of the table or its own) on `joints`, named `<name>-<servo>`; a
    stated total mass moves by the servos' difference; ValueError for an unknown joint or servo,
    or a servo the robot's output or supply cannot drive (the description's own checks)."""
    table = desc.servo_catalogue()
    if servo not in table:
        raise ValueError(f"unknown servo {servo!r}; known: {', '.join(sorted(table))}")
    unknown = [j for j in joints if j not in JOINT_NAMES]
    if unknown or not joints:
        raise ValueError(f"joints must be some of {', '.join(JOINT_NAMES)}; got {list(joints)}")
    data = desc.model_dump(mode="json")
    mass = desc.total_mass_kg
    for joint in joints:
        if mass is not None:
            mass += table[servo].mass_kg - table[desc.joint_servo(joint)].mass_kg
        data["joints"][joint]["servo"] = servo
    tag = servo.lower().replace("-", "")
    data["name"] = derived_name(desc.name, tag)
    data["title"] = f"{desc.title}; {servo} on {', '.join(joints)}"[:200]
    if mass is not None:
        data["total_mass_kg"] = round(mass, 6)
    return RobotDescription.model_validate(data)


class _Dumper(yaml.SafeDumper):
    """Lists of numbers on one line, as a person writes a size or a position."""


def _list(dumper: yaml.SafeDumper, items: list) -> yaml.Node:
    flat = all(isinstance(item, int | float | str | bool) for item in items)
    return dumper.represent_sequence("tag:yaml.org,2002:seq", items, flow_style=flat)


_Dumper.add_representer(list, _list)


def write_description(desc: RobotDescription, path: Path, header: str = "") -> Path:
    """`desc` as a description file (`--robot FILE` reads it back to the same robot): what
    differs from the defaults, lists of numbers on a line, `header` as comment lines first."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fields = {"schema_version": desc.schema_version}
    fields |= desc.model_dump(mode="json", exclude_defaults=True)
    text = yaml.dump(fields, Dumper=_Dumper, sort_keys=False, allow_unicode=True, width=100)
    comments = "".join(f"# {line}\n" for line in header.splitlines())
    path.write_text(comments + text, encoding="utf-8")
    return path
