"""A change of several gait constants at once (a preset, an import) reaches the servos over
GAIT_RAMP_S, as a change of motion goes through the motion ramp (docs/DESIGN.md §4, §14): the
simulation thread gives the frame loop a blend of the old and the new constants each frame."""

from __future__ import annotations

from typing import Any

from gait import GaitParams
from gait.params import merge

GAIT_RAMP_S = 2.0


def gait_fields_changed(a: GaitParams, b: GaitParams) -> int:
    """How many constants (and the engine) differ between two sets."""
    fb = b.flat()
    return sum(1 for name, value in a.flat().items() if fb[name] != value)


def blend(a: GaitParams, b: GaitParams, s: float) -> GaitParams:
    """`a` moved the share `s` (0..1) of the way to `b`: numbers linearly (a straight line inside
    the schema's ranges stays inside them), switches and the engine at s = 1/2. ValueError if
    `merge` refuses the blend."""
    patch: dict[str, Any] = {}
    fb = b.flat()
    for dotted, va in a.flat().items():
        vb = fb[dotted]
        if isinstance(va, bool | str) or isinstance(vb, bool | str):
            value = vb if s >= 0.5 else va
        else:
            value = va * (1.0 - s) + vb * s  # exact at both ends
        if dotted == "engine":
            patch["engine"] = value
        else:
            group, _, field = dotted.partition(".")
            patch.setdefault(group, {})[field] = value
    return merge(a, patch)


class GaitRamp:
    """From the constants in effect to a new set, one blend per 20 ms frame over `frames`."""

    def __init__(self, start: GaitParams, target: GaitParams, frames: int) -> None:
        self.start, self.target, self.frames = start, target, max(1, frames)
        self.done_frames = 0

    @property
    def progress(self) -> float:
        return self.done_frames / self.frames

    @property
    def finished(self) -> bool:
        return self.done_frames >= self.frames

    def next(self) -> GaitParams:
        """The constants of the next frame (the target itself at the end)."""
        self.done_frames = min(self.done_frames + 1, self.frames)
        if self.finished:
            return self.target
        try:
            return blend(self.start, self.target, self.progress)
        except ValueError:  # a blend the schema refuses: go to the target at once
            self.done_frames = self.frames
            return self.target
