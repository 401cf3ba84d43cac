"""Parameter sets on disk: one JSON document with the motion vector, CA and every gait constant.

The document's layout and its checks are `ParameterSet`'s (docs/DESIGN.md §6).
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any

from app.assets import project_version
from gait import GaitParams, Motion
from gait.params import replace_checked

ROBOT_NAME = re.compile(r"[a-z][a-z0-9_-]{0,39}")  # as a robot description's `name`
SCHEMA_VERSION = 2
#: Versions `ParameterSet.from_dict` reads (see the module docstring for what 1 lacks).
READABLE_VERSIONS = (1, 2)
V2_GROUPS = ("steer", "ramp", "pfs")
TOP_LEVEL_KEYS = (
    "schema_version",
    "name",
    "robot",
    "created",
    "project_version",
    "motion",
    "gait",
)
#: The robot a set was tuned for when it does not say: every set before robots existed was ArtRo's.
DEFAULT_ROBOT = "artro"


@dataclass(frozen=True)
class ParameterSet:
    """One parameter set: provenance, the motion vector with CA, and every gait constant.

    As a document (`to_dict`, `from_dict`, docs/DESIGN.md §6):

        {"schema_version": 2, "name": "...", "robot": "artro", "created": "ISO time",
         "project_version": "0.2.0",
         "motion": {"a_r": 0, "a_p": 0.07, "a_y": 0, "ca": 0},
         "gait": {"engine": "behnke", "clock": {...}, "shift": {...}, ..., "leg": {...},
                  "steer": {...}, "ramp": {...}, "pfs": {...}}}

    Groups or fields left out take the paper's value; unknown keys are errors that name what is
    allowed. Schema version 2 added the engine, `steer`, `ramp` and `pfs` (docs/DESIGN.md §4); a
    version 1 document reads as what it meant: the behnke engine, K = 0, the other new groups at
    their defaults (the ramp only shapes changes of motion, so a v1 set's runs measure as before).
    """

    name: str = "paper"
    #: the robot it was tuned for (docs/DESIGN.md §7); optional in a document, default artro
    robot: str = DEFAULT_ROBOT
    motion: Motion = field(default_factory=Motion)
    gait: GaitParams = field(default_factory=GaitParams)
    created: str = ""
    project_version: str = ""

    def to_dict(self) -> dict[str, Any]:
        """The document; an empty `created` / `project_version` becomes now (UTC) / ours."""
        return {
            "schema_version": SCHEMA_VERSION,
            "name": self.name,
            "robot": self.robot,
            "created": self.created or datetime.now(UTC).isoformat(timespec="seconds"),
            "project_version": self.project_version or project_version(),
            "motion": dataclasses.asdict(self.motion),
            "gait": self.gait.to_dict(),
        }

    @classmethod
    def from_dict(cls, data: Any) -> ParameterSet:
        """Check and build from a document (e.g. parsed JSON); ValueError says what is wrong and
        what is allowed (unknown keys, schema version, types, ranges)."""
        if not isinstance(data, dict):
            raise ValueError("a parameter set must be a JSON object")
        unknown = sorted(set(data) - set(TOP_LEVEL_KEYS))
        if unknown:
            raise ValueError(f"unknown keys {unknown}; allowed: {list(TOP_LEVEL_KEYS)}")
        version = data.get("schema_version", SCHEMA_VERSION)
        if isinstance(version, bool) or version not in READABLE_VERSIONS:
            raise ValueError(
                f"schema_version {version!r} is not supported; this is {SCHEMA_VERSION}, "
                f"and it reads {', '.join(map(str, READABLE_VERSIONS))}"
            )
        gait = data.get("gait", {})
        if version == 1 and isinstance(gait, dict):
            newer = sorted(set(gait) & {"engine", *V2_GROUPS})
            if newer:
                raise ValueError(f"schema_version 1 has no {newer}; write schema_version 2")
        name = data.get("name", "unnamed")
        if not isinstance(name, str):
            raise ValueError("name must be a string")
        robot = data.get("robot", DEFAULT_ROBOT)
        if not isinstance(robot, str) or not ROBOT_NAME.fullmatch(robot):
            raise ValueError(
                f"robot must be a robot's name (lower case letters, digits, - and _, up to 40), "
                f"got {robot!r}"
            )
        return cls(
            name=name,
            robot=robot,
            motion=replace_checked(Motion(), data.get("motion", {}), "motion"),
            gait=GaitParams.from_dict(gait),
            created=str(data.get("created", "")),
            project_version=str(data.get("project_version", "")),
        )
