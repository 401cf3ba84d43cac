"""Other servos on some joints (docs/DESIGN.md §7): the servo of the table that carries a torque
with eq (1)'s safety factor, and the robot with it swapped in -- its description with those
joints' servo changed and the stated total mass moved by the servos' mass difference, so the
masses still add up and the model carries the new servos' mass, torque and speed."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import yaml

from app.robots.description import RobotDescription
from app.robots.servos import rating_at, servo_table
from gait import JOINT_NAMES


@dataclass(frozen=True)
class ServoChoice:
    name: str
    stall_torque_nm: float  # at the robot's supply voltage
    mass_kg: float


def servo_choices(voltage_v: float, signal: str = "pwm") -> list[ServoChoice]:
    """The table's servos of `signal` rated at `voltage_v`, weakest first."""
    out = []
    for name, spec in servo_table().items():
        if spec.signal != signal:
            continue
        try:
            stall, _speed, _interpolated = rating_at(spec, voltage_v, name)
        except ValueError:  # not rated at this supply
            continue
        out.append(ServoChoice(name, stall, spec.mass_kg))
    return sorted(out, key=lambda c: (c.stall_torque_nm, c.mass_kg))


def smallest_servo(need_nm: float, voltage_v: float, signal: str = "pwm") -> ServoChoice | None:
    """The weakest servo of the table whose stall torque at `voltage_v` is at least `need_nm`
    (None: none is that strong)."""
    return next((c for c in servo_choices(voltage_v, signal) if c.stall_torque_nm >= need_nm), None)


def with_servo(desc: RobotDescription, joints: Sequence[str], servo: str) -> RobotDescription:
    """`desc` with `servo` on `joints`, named `<name>-<servo>`; ValueError for an unknown joint
    or servo, or a servo the robot's output or supply cannot drive (the description's own
    checks)."""
    table = servo_table()
    if servo not in table:
        raise ValueError(f"unknown servo {servo!r}; the servo table has {', '.join(sorted(table))}")
    unknown = [j for j in joints if j not in JOINT_NAMES]
    if unknown or not joints:
        raise ValueError(f"joints must be some of {', '.join(JOINT_NAMES)}; got {list(joints)}")
    data = desc.model_dump(mode="json")
    mass = desc.total_mass_kg
    for joint in joints:
        mass += table[servo].mass_kg - table[desc.joint_servo(joint)].mass_kg
        data["joints"][joint]["servo"] = servo
    tag = servo.lower().replace("-", "")
    data["name"] = f"{desc.name}-{tag}"[:40]
    data["title"] = f"{desc.title}; {servo} on {', '.join(joints)}"
    data["total_mass_kg"] = round(mass, 6)
    return RobotDescription.model_validate(data)


def write_description(desc: RobotDescription, path: Path) -> Path:
    """`desc` as a description file (`--robot FILE` reads it back to the same robot)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    text = yaml.safe_dump(desc.model_dump(mode="json"), sort_keys=False, allow_unicode=True)
    path.write_text(text, encoding="utf-8")
    return path
