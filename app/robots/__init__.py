"""Robots as descriptions (docs/DESIGN.md §7): the schema, the servo table, the model builder,
the checks that run before anything simulates, and the built-in robots; the compiled model with
its joint addresses is `app.robots.model.RobotModel`."""

from app.robots.builder import build_model, build_spec, joint_settings, model_xml
from app.robots.description import RobotDescription
from app.robots.description_parts import Calibration, Geometry, Joint, Part
from app.robots.library import (
    BUILTIN_DEFAULT,
    RobotError,
    builtin_robot_names,
    load_description,
    not_a_builtin_impostor,
    parse_description,
)
from app.robots.servos import ServoSettings, ServoSpec, servo_settings, servo_table

__all__ = [
    "BUILTIN_DEFAULT",
    "Calibration",
    "Geometry",
    "Joint",
    "Part",
    "RobotDescription",
    "RobotError",
    "ServoSettings",
    "ServoSpec",
    "build_model",
    "build_spec",
    "builtin_robot_names",
    "joint_settings",
    "load_description",
    "model_xml",
    "not_a_builtin_impostor",
    "parse_description",
    "servo_settings",
    "servo_table",
]
