"""What other threads may ask of the simulation thread (docs/DESIGN.md §10): one frozen
dataclass per command, `SimCommand` their union, and the queue where they wait for the next frame
boundary. A bad command is refused with a ValueError where it is made, in the sender's thread."""

from __future__ import annotations

import math
import queue
import threading
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import ClassVar

from app.server.sim.emulated_controller import EmulatedController
from app.server.sim.pacing import SPEED_RANGE
from app.worlds.variations import Variation
from gait import GaitParams


@dataclass(frozen=True)
class Pause:
    """Stop the frame loop; the robot stays as it is."""

    name: ClassVar[str] = "pause"


@dataclass(frozen=True)
class PauseForReplay(Pause):
    """Pause, and answer whether the loop was paused already (`was_paused`, put once the
    simulation thread takes it): a replay resumes on leaving only a simulation it found running,
    which a published status up to a frame old cannot tell."""

    was_paused: queue.Queue[bool] = field(
        default_factory=lambda: queue.Queue(maxsize=1), compare=False
    )


@dataclass(frozen=True)
class Resume:
    """Run the frame loop again, paced from now."""

    name: ClassVar[str] = "resume"


@dataclass(frozen=True)
class Reset:
    """Stand the robot at the start; the real-time factor restarts."""

    name: ClassVar[str] = "reset"


@dataclass(frozen=True)
class Step:
    """One 20 ms frame, pausing first."""

    name: ClassVar[str] = "step"


@dataclass(frozen=True)
class SetSpeed:
    """Run at `speed` x real time, within SPEED_RANGE."""

    speed: float
    name: ClassVar[str] = "speed"

    def __post_init__(self) -> None:
        lo, hi = SPEED_RANGE
        value = self.speed
        if isinstance(value, bool) or not isinstance(value, int | float) or not lo <= value <= hi:
            raise ValueError(f"speed must be {lo} to {hi} (x real time), got {value!r}")
        object.__setattr__(self, "speed", float(value))


@dataclass(frozen=True)
class Reanchor:
    """Start the path prediction again at the robot's pose, with V fixed by hand (m/s) or, None,
    measured."""

    speed_m_s: float | None = None
    name: ClassVar[str] = "reanchor"

    def __post_init__(self) -> None:
        value = self.speed_m_s
        if value is None:
            return
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise ValueError(f"reanchor takes a finite speed in m/s or None, got {value!r}")
        object.__setattr__(self, "speed_m_s", float(value))


class DriveRefused(ValueError):
    """A drive switch refused; `reason` names why for the API's error type: `robot_changed`
    (the robot changed while the firmware booted), `unsupported_engine` (the set names an
    engine the firmware does not run) or `drive_failed` (handing the pulses over failed)."""

    def __init__(self, message: str, reason: str) -> None:
        super().__init__(message)
        self.reason = reason


class DriveAnswer:
    """The simulation thread's verdict on one `SwitchDrive`: given once; `refusal` says why not,
    `reason` names it (as `DriveRefused.reason`)."""

    def __init__(self) -> None:
        self._given = threading.Event()
        self.refusal: str | None = None
        self.reason = ""

    def give(self, refusal: str | None, reason: str = "") -> None:
        self.refusal, self.reason = refusal, reason
        self._given.set()

    def wait(self, timeout_s: float) -> bool:
        """True once the verdict is given; False if `timeout_s` passed first."""
        return self._given.wait(timeout_s)


@dataclass(frozen=True)
class SwitchDrive:
    """Hand the pulses to a booted emulated controller (the firmware drive), or, None, to the
    Python hardware model. The simulation thread answers in `answer`: the firmware is refused if
    the set has come to name another engine while it booted."""

    controller: EmulatedController | None
    answer: DriveAnswer = field(default_factory=DriveAnswer, compare=False)
    name: ClassVar[str] = "drive"

    def __post_init__(self) -> None:
        if not isinstance(self.controller, EmulatedController | None):
            raise ValueError(
                "the drive command takes a booted EmulatedController or None (the model), "
                f"got {type(self.controller).__name__}"
            )


@dataclass(frozen=True)
class SetGhost:
    """Let the gait constants `params` walk beside the live robot as the A/B ghost, labelled
    `source` ("preset tuned", "version 12"); it replaces any ghost there was."""

    params: GaitParams
    source: str
    name: ClassVar[str] = "ghost"

    def __post_init__(self) -> None:
        if not isinstance(self.params, GaitParams) or not isinstance(self.source, str):
            raise ValueError("the ghost command takes GaitParams and a source label (str)")


@dataclass(frozen=True)
class RemoveGhost:
    """No ghost."""

    name: ClassVar[str] = "ghost"


@dataclass(frozen=True)
class SetWorld:
    """Walk on in another world (a model variation, docs/DESIGN.md §8) from the next frame; the
    robot is not reset."""

    variation: Variation
    name: ClassVar[str] = "world"

    def __post_init__(self) -> None:
        if not isinstance(self.variation, Variation):
            raise ValueError("the world command takes a Variation")


PUSH_RANGE_N_S = (0.01, 2.0)  # a tap to a shove that fells ArtRo from any direction


@dataclass(frozen=True)
class Push:
    """Push the trunk in the next physics step: `impulse_n_s` (within PUSH_RANGE_N_S), level,
    toward `direction_deg` counter-clockwise from where the robot faces (0 forward, 90 left)."""

    impulse_n_s: float
    direction_deg: float = 0.0
    name: ClassVar[str] = "push"

    def __post_init__(self) -> None:
        lo, hi = PUSH_RANGE_N_S
        impulse, direction = self.impulse_n_s, self.direction_deg
        for value in (impulse, direction):
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ValueError(f"a push takes numbers, got {value!r}")
        if not lo <= impulse <= hi:
            raise ValueError(f"a push's impulse must be {lo} to {hi} N·s, got {impulse!r}")
        if not math.isfinite(direction):
            raise ValueError(
                f"a push's direction must be a finite angle in degrees, got {direction!r}"
            )
        object.__setattr__(self, "impulse_n_s", float(impulse))
        object.__setattr__(self, "direction_deg", (float(direction) + 180.0) % 360.0 - 180.0)


#: the impulse that may wait for the physics step at once: pushes sent while paused (or within
#: one frame) act together in the next step, and so add up; past a push's own cap they are refused
PUSH_PENDING_MAX_N_S = PUSH_RANGE_N_S[1]


class PushRefused(ValueError):
    """A push refused because those waiting for the next physics step would add up past
    PUSH_PENDING_MAX_N_S."""


class PendingPushes:
    """The impulse of the pushes sent that have not acted yet, bounded by PUSH_PENDING_MAX_N_S:
    any thread adds one (`admit`), the simulation thread takes off those that acted or were
    dropped (`settle`), under a lock."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._n_s = 0.0

    @property
    def n_s(self) -> float:
        return self._n_s

    def admit(self, push: Push) -> None:
        """Count `push` as waiting; PushRefused, counting nothing, past PUSH_PENDING_MAX_N_S."""
        with self._lock:
            waiting = self._n_s
            if waiting + push.impulse_n_s > PUSH_PENDING_MAX_N_S + 1e-9:
                left = max(0.0, PUSH_PENDING_MAX_N_S - waiting)
                raise PushRefused(
                    f"{waiting:.2f} N·s of pushes already wait for the next physics step (the "
                    f"simulation is paused, or they came within one frame) and act there as one "
                    f"push: at most {PUSH_PENDING_MAX_N_S:g} N·s may wait, so at most "
                    f"{left:.2f} N·s more now; resume or step (POST /api/sim/resume or "
                    "/api/sim/step) and push again"
                )
            self._n_s = waiting + push.impulse_n_s

    def settle(self, n_s: float) -> None:
        """`n_s` of the pushes waiting acted, or were dropped (simulation thread)."""
        if n_s:
            with self._lock:
                self._n_s = max(0.0, self._n_s - n_s)


SimCommand = (
    Pause
    | Resume
    | Reset
    | Step
    | SetSpeed
    | Reanchor
    | SwitchDrive
    | SetGhost
    | RemoveGhost
    | SetWorld
    | Push
)
Control = Reset | Pause | Resume | Step  # the controls of the page, the API and the 3D view

CONTROLS: dict[str, Control] = {c.name: c for c in (Reset(), Pause(), Resume(), Step())}


def control(name: str) -> Control:
    """The control named `name` (reset, pause, resume, step); ValueError naming those."""
    try:
        return CONTROLS[name]
    except KeyError:
        allowed = ", ".join(CONTROLS)
        raise ValueError(f"unknown command {name!r}; allowed: {allowed}") from None


class CommandQueue:
    """Commands from any thread, taken by the simulation thread at its next frame boundary in
    the order they were put; putting one wakes the thread."""

    def __init__(self, wake: threading.Event) -> None:
        self._queue: queue.SimpleQueue[SimCommand] = queue.SimpleQueue()
        self._wake = wake

    def put(self, command: SimCommand) -> None:
        if not isinstance(command, SimCommand):
            raise ValueError(f"not a command of the simulation thread: {command!r}")
        self._queue.put(command)
        self._wake.set()

    def drain(self) -> Iterator[SimCommand]:
        """The commands queued now, oldest first (simulation thread only)."""
        while True:
            try:
                yield self._queue.get_nowait()
            except queue.Empty:
                return
