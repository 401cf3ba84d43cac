"""The identification routine (docs/FIT.md): a fixed sequence of segments (standing still, weight
shifts, steps on the spot, short walks forward, sideways and turning) that a robot plays, on the
link or in simulation, so that a recording of it can be fitted (`app.study.fit`)."""

from __future__ import annotations

import dataclasses
import zlib
from dataclasses import dataclass, field

from gait import GaitParams, Motion
from gait.feedback import LAW_GROUPS

#: the gait's primitives a segment may hold still (docs/DESIGN.md §4)
PRIMITIVES = ("shift", "short", "swing", "load", "balance")
FRAME_S = 0.02


@dataclass(frozen=True)
class Segment:
    """A stretch of the routine: `seconds` of `motion`, with the gait primitives in `still` off
    (all off: the robot stands in its mean pose; all but `shift`: it shifts its weight)."""

    name: str
    seconds: float
    motion: Motion = field(default_factory=Motion)
    still: tuple[str, ...] = ()
    #: the lateral shift's amplitude as a share of the set's (weight shifts without steps sway
    #: the trunk further than with them: the feet stay down)
    shift_scale: float = 1.0

    @property
    def frames(self) -> int:
        return round(self.seconds / FRAME_S)


STAND = PRIMITIVES
SWAY = tuple(p for p in PRIMITIVES if p != "shift")

#: about 60 s; amplitudes in the motion vector's units (docs/DESIGN.md §3), small enough for a
#: robot that walks the paper's cases: forward a_p 0.05 (the paper's 0.07), sideways ±0.05,
#: turning a_y ±0.1. Each walk ends on the spot, so the ramp starts each from the same gait.
IDENTIFY = (
    Segment("stand", 5.0, still=STAND),
    Segment("weight shifts", 8.0, still=SWAY, shift_scale=0.7),
    Segment("on the spot", 6.0),
    Segment("forward", 9.0, Motion(a_p=0.05)),
    Segment("on the spot 2", 3.0),
    Segment("right", 6.0, Motion(a_r=0.05)),
    Segment("left", 6.0, Motion(a_r=-0.05)),
    Segment("turn clockwise", 6.0, Motion(a_y=0.1)),
    Segment("turn anticlockwise", 6.0, Motion(a_y=-0.1)),
    Segment("stand 2", 5.0, still=STAND),
)
ROUTINES = {"identify": IDENTIFY}
ROUTINE_VERSION = 1


def routine_id(name: str) -> str:
    """A routine's name and a CRC-32 of its segments: two recordings of one routine share it."""
    text = repr((ROUTINE_VERSION, ROUTINES[name]))
    return f"{name}-v{ROUTINE_VERSION}-{zlib.crc32(text.encode()):08x}"


def total_frames(routine: tuple[Segment, ...]) -> int:
    return sum(s.frames for s in routine)


def open_loop(params: GaitParams) -> GaitParams:
    """`params` with every balance law off: the routine's commands are the gait's alone, so a
    fit replays them exactly (a law would answer the robot's own sensors)."""
    return dataclasses.replace(
        params, **{g: dataclasses.replace(getattr(params, g), enabled=False) for g in LAW_GROUPS}
    )


def segment_params(params: GaitParams, segment: Segment) -> GaitParams:
    """The open-loop gait of a segment: `params` with its `still` primitives off."""
    off = {g: dataclasses.replace(getattr(params, g), enabled=False) for g in segment.still}
    shift = params.shift
    if segment.shift_scale != 1.0 and "shift" not in segment.still:
        off["shift"] = dataclasses.replace(shift, amp_base=shift.amp_base * segment.shift_scale)
    return dataclasses.replace(open_loop(params), **off)
