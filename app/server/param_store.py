"""The one parameter store: an immutable snapshot plus a version number (docs/DESIGN.md §11).
Every change goes through `ParameterStore.update` or `replace` (validated, diffed, applied under a
lock, announced outside it); undo and redo walk a bounded history, one step per gesture (§14).
The robot being simulated is part of each version: switching robots is a change that undo takes
back like any other (§7)."""

from __future__ import annotations

import dataclasses
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from app.params.document import DEFAULT_ROBOT, ParameterSet
from gait import GaitParams, Motion
from gait.params import merge, replace_checked

HISTORY_LIMIT = 200


@dataclass(frozen=True)
class Snapshot:
    version: int
    name: str
    motion: Motion
    gait: GaitParams
    source: str = "start"  # who made this version: "http", "viser", "preset", "import", "undo"...
    gesture: str | None = None  # the gesture (one drag, one key burst) that made it, if named
    robot: str = DEFAULT_ROBOT  # the robot being simulated: the sets of this store are for it

    def flat(self) -> dict[str, float | bool]:
        """Dotted field names -> values: 'motion.a_p', 'swing.v', ..."""
        motion = {f"motion.{k}": v for k, v in dataclasses.asdict(self.motion).items()}
        return motion | self.gait.flat()

    def to_dict(self) -> dict[str, Any]:
        return {
            "version": self.version,
            "name": self.name,
            "robot": self.robot,
            "motion": dataclasses.asdict(self.motion),
            "gait": self.gait.to_dict(),
        }

    def parameter_set(self) -> ParameterSet:
        return ParameterSet(name=self.name, robot=self.robot, motion=self.motion, gait=self.gait)


Subscriber = Callable[[Snapshot, frozenset[str], str], None]
#: Called with the current snapshot under the store's lock before a change; raising refuses it
#: with nothing changed (optimistic concurrency: "only if the version is still n").
Check = Callable[[Snapshot], None]
#: called with the snapshot in use and the robot a change would switch to, under the store's
#: lock, before anything changes; raises RobotBusy to refuse (it must not use the store)
RobotGuard = Callable[[Snapshot, str], None]


class RobotBusy(RuntimeError):
    """A change of robots refused: something runs on the robot in use."""


class NothingToUndo(LookupError):
    pass


class ParameterStore:
    def __init__(self, initial: ParameterSet | None = None, robot: str = DEFAULT_ROBOT) -> None:
        """A store of parameter sets, the first simulated on `robot` (whatever robot `initial`
        names)."""
        initial = initial or ParameterSet()
        self._lock = threading.Lock()
        self._snapshot = Snapshot(1, initial.name, initial.motion, initial.gait, robot=robot)
        #: decides every change of robots, a switch, undo or redo (`Services` sets it)
        self.robot_guard: RobotGuard | None = None
        self._undo: list[Snapshot] = []
        self._redo: list[Snapshot] = []
        self._subscribers: list[Subscriber] = []

    def snapshot(self) -> Snapshot:
        return self._snapshot  # immutable: safe to hand out without the lock

    @property
    def robot(self) -> str:
        """The robot the version in use is simulated on."""
        return self._snapshot.robot

    def settled_robot(self) -> str:
        """The robot in use once a change being made has landed (a change of robots holds the
        lock from its guard to its commit): what a job just registered checks it walks."""
        with self._lock:
            return self._snapshot.robot

    def subscribe(self, callback: Subscriber) -> Callable[[], None]:
        """Call `callback(snapshot, changed, source)` after every change; returns unsubscribe."""
        with self._lock:
            self._subscribers.append(callback)

        def unsubscribe() -> None:
            with self._lock:
                if callback in self._subscribers:
                    self._subscribers.remove(callback)

        return unsubscribe

    # --- changes -------------------------------------------------------------------------------

    def update(
        self,
        patch: Mapping[str, Any],
        source: str,
        *,
        check: Check | None = None,
        gesture: str | None = None,
    ) -> Snapshot:
        """Merge a partial {'motion': {...}, 'gait': {group: {...}}}; ValueError changes nothing.

        `gesture` names the user's gesture the change belongs to (one drag of a slider, one burst
        of key presses): while the version in use was made by the same gesture and source, the
        change is a new version but no new undo step, so one undo goes back to before the
        gesture."""
        unknown = set(patch) - {"motion", "gait", "name"}
        if unknown:
            raise ValueError(f"unknown keys {sorted(unknown)}; allowed: motion, gait, name")

        def build(current: Snapshot) -> tuple[str, Motion, GaitParams]:
            motion = current.motion
            if "motion" in patch:
                motion = replace_checked(current.motion, patch["motion"], "motion")
            gait = merge(current.gait, patch["gait"]) if "gait" in patch else current.gait
            return patch.get("name", current.name), motion, gait

        return self._commit(build, source, check, gesture)

    def replace(
        self,
        pset: ParameterSet,
        source: str,
        *,
        check: Check | None = None,
        robot: str | None = None,
    ) -> Snapshot:
        """Replace every parameter (a PUT, a loaded preset, an import); with `robot`, also the
        robot it is simulated on (a switch of robots; default: the robot in use stays)."""
        return self._commit(
            lambda _current: (pset.name, pset.motion, pset.gait), source, check, robot=robot
        )

    def undo(self, source: str, *, check: Check | None = None) -> Snapshot:
        """Go back one change (whoever made it: `check` sees the snapshot being replaced)."""
        return self._step_history(self._undo, self._redo, source, check)

    def redo(self, source: str, *, check: Check | None = None) -> Snapshot:
        """Go forward one undone change."""
        return self._step_history(self._redo, self._undo, source, check)

    def versions(self) -> list[Snapshot]:
        """The current version and the earlier ones undo can go back to, newest first."""
        with self._lock:
            return [self._snapshot, *reversed(self._undo)]

    @property
    def can_undo(self) -> bool:
        return bool(self._undo)

    @property
    def can_redo(self) -> bool:
        return bool(self._redo)

    # --- internals ------------------------------------------------------------------------------

    def _commit(
        self,
        build: Callable[[Snapshot], tuple[str, Motion, GaitParams]],
        source: str,
        check: Check | None,
        gesture: str | None = None,
        *,
        robot: str | None = None,
    ) -> Snapshot:
        with self._lock:
            current = self._snapshot
            if check is not None:
                check(current)  # raises before anything changes
            self._guard_robot(current, robot or current.robot)
            name, motion, gait = build(current)  # raises before anything changes
            candidate = Snapshot(
                current.version + 1,
                name,
                motion,
                gait,
                source,
                gesture=gesture,
                robot=robot or current.robot,
            )
            changed = _changed(current, candidate)
            if not changed:
                return current
            same_gesture = gesture is not None and (current.gesture, current.source) == (
                gesture,
                source,
            )
            if not (same_gesture and self._undo):
                self._undo.append(current)
                del self._undo[:-HISTORY_LIMIT]
            elif not _changed(self._undo[-1], candidate):
                # the gesture came back to where it started: nothing of it to undo, and its next
                # step is a new undo step again
                self._undo.pop()
                candidate = dataclasses.replace(candidate, gesture=None)
            self._redo.clear()
            self._snapshot = candidate
            subscribers = list(self._subscribers)
        self._announce(subscribers, candidate, changed, source)
        return candidate

    def _step_history(
        self, take: list[Snapshot], give: list[Snapshot], source: str, check: Check | None
    ) -> Snapshot:
        with self._lock:
            current = self._snapshot
            if check is not None:
                check(current)
            if not take:
                raise NothingToUndo("nothing to undo" if take is self._undo else "nothing to redo")
            self._guard_robot(current, take[-1].robot)
            previous = take.pop()
            give.append(current)
            candidate = Snapshot(
                current.version + 1,
                previous.name,
                previous.motion,
                previous.gait,
                source,
                robot=previous.robot,
            )
            self._snapshot = candidate
            changed = _changed(current, candidate)
            subscribers = list(self._subscribers)
        self._announce(subscribers, candidate, changed, source)
        return candidate

    def _guard_robot(self, current: Snapshot, robot: str) -> None:
        if robot != current.robot and self.robot_guard is not None:
            self.robot_guard(current, robot)

    @staticmethod
    def _announce(
        subscribers: list[Subscriber], snapshot: Snapshot, changed: frozenset[str], source: str
    ) -> None:
        for callback in subscribers:
            callback(snapshot, changed, source)


def _changed(a: Snapshot, b: Snapshot) -> frozenset[str]:
    fa, fb = a.flat(), b.flat()
    names = {k for k in fa if fa[k] != fb[k]}
    names |= {key for key in ("name", "robot") if getattr(a, key) != getattr(b, key)}
    return frozenset(names)
