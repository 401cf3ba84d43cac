"""The robots a running server can simulate: the one it was started with, the built-in ones and
those imported on the dashboard, each built once and kept (a switch of robots, or an undo of one,
is then a frame's work). The API switches only among these; no request names a file on the
server's disk (docs/DESIGN.md §7)."""

from __future__ import annotations

import threading

from app.robots import builtin_robot_names, not_a_builtin_impostor
from app.robots.model import RobotModel


class UnknownRobot(ValueError):
    """A robot name this server does not offer; the message lists those it does."""


class RobotShelf:
    def __init__(self, started: RobotModel) -> None:
        """ValueError if `started` is not a built-in robot but takes a built-in's name (it
        would hide that robot)."""
        not_a_builtin_impostor(started.description, "the robot started with")
        self.started = started
        self._built: dict[str, RobotModel] = {started.name: started}
        self._added: list[str] = []  # imported on the dashboard (`RobotImporter`)
        self._lock = threading.Lock()

    def names(self) -> list[str]:
        """The robots on offer: the one started with first, the built-in ones, those imported."""
        builtins = (n for n in builtin_robot_names() if n != self.started.name)
        return [self.started.name, *builtins, *self._added]

    def add(self, robot: RobotModel) -> None:
        """Offer `robot` (built from an imported file) from now on; ValueError if its name is
        on offer already or is a built-in robot's."""
        not_a_builtin_impostor(robot.description, "the robot imported")
        with self._lock:
            if robot.name in self.names():
                raise ValueError(f"a robot named {robot.name!r} is on offer already")
            self._built[robot.name] = robot
            self._added = [*self._added, robot.name]

    def get(self, name: str) -> RobotModel:
        """The built model of `name` (built on first use); UnknownRobot for any other name."""
        if name not in self.names():
            raise UnknownRobot(
                f"unknown robot {name!r}; this server offers {', '.join(self.names())}"
            )
        with self._lock:
            if name not in self._built:
                self._built[name] = RobotModel.load(name)
            return self._built[name]
