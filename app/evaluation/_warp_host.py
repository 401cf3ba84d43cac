"""A MuJoCo Warp batch's worlds on the host between the device's segments (docs/GPU.md "Where
the time goes"): the batch planned (`plan_batch`), the closed-loop worlds' loops per frame
(`WorldLoops`), the frame ends tested and the worlds that ended measured (`WorldEnds`); the
work per world is `_warp_pool.py`'s, here or over its worker processes. No Warp here."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from app.evaluation._api import Job
from app.evaluation._frames import ClosedLoops, Start, walk_of
from app.evaluation._measure import not_finite
from app.evaluation._warp_pool import (
    HostArray,
    HostPool,
    Measured,
    initial_arrays,
    measure_world,
    plan_worlds,
    shared_memory_short,
    varied_robots,
)
from app.robots.model import RobotModel
from app.sim.metrics import RunMetrics, Trace
from app.sim.robot_pose import has_fallen
from app.worlds.variations import Variation

#: a call of fewer worlds is planned and measured in the calling process: starting the pool
#: (each worker imports the project, ~1-2 s) is worth a few hundred worlds' planning, and the
#: pool is then kept for the evaluator's later calls
POOL_MIN_WORLDS = 256


@dataclass
class Planned:
    """A batch's worlds as `plan_batch` planned them."""

    #: each world's robot as its variation varies it (one object per distinct variation)
    robots: list[RobotModel]
    starts: list[Start]
    #: every world's ctrl of every step (`controls.array`: worlds x steps x nu, float32);
    #: `controls.release()` on every path
    controls: HostArray
    #: each world's `INITIAL` rows
    initial: dict[str, np.ndarray]
    #: the loops between frames of the worlds where a law is on (`ClosedLoops`, the lanes')
    loops: WorldLoops


def plan_batch(
    robot: RobotModel,
    jobs: Sequence[Job],
    n_frames: int,
    steps: int,
    pool: HostPool | None,
    notice: Callable[[str], None] | None,
    with_robots: Callable[[list[RobotModel]], None] | None = None,
) -> Planned:
    """Every world planned (`plan_worlds`): on `pool` where one is given and the controls fit
    in shared memory (else here, `notice` told why), the varied robots made here meanwhile
    and handed to `with_robots` (the device's per-world values are read from them while the
    workers plan); the worlds with a law on get their loops here (`WorldLoops`), from their
    starts. The controls are released when planning fails."""
    shape = (len(jobs), n_frames * steps, robot.model.nu)
    short = None if pool is None else shared_memory_short(math.prod(shape) * 4)
    if short is not None and notice is not None:
        notice(short)
    controls = HostArray(shape, shared=pool is not None and short is None)
    try:
        control, initial = controls.array, initial_arrays(robot.model, len(jobs))
        varied: dict[Variation, RobotModel] = {}
        robots: list[RobotModel] = []

        def make_robots() -> None:
            robots.extend(varied_robots(robot, jobs, varied))
            if with_robots is not None:
                with_robots(robots)

        if pool is not None and controls.name is not None:
            starts, first_rows = pool.plan(jobs, n_frames, controls, initial, make_robots)
        else:
            make_robots()
            data = mujoco.MjData(robot.model)
            starts, first_rows = plan_worlds(robots, jobs, n_frames, control, initial, {}, data)
        loops = WorldLoops(robots, jobs, starts, steps, first_rows)
    except BaseException:
        controls.release()
        raise
    return Planned(robots, starts, controls, initial, loops)


class WorldLoops:
    """A batch's closed-loop worlds' loops between frames: the worlds of one walk (`walk_of`)
    in one `ClosedLoops`, their sensors, laws and frames planned at once as the lanes' groups
    plan them. A world that stops counting leaves its group.

    Args:
        robots, jobs, starts: every world's.
        steps: physics steps per frame.
        first_rows: the closed-loop worlds' sensordata standing at the start, by world.
    """

    def __init__(
        self,
        robots: Sequence[RobotModel],
        jobs: Sequence[Job],
        starts: Sequence[Start],
        steps: int,
        first_rows: dict[int, np.ndarray],
    ) -> None:
        walks: dict[tuple, list[int]] = {}
        for w in sorted(first_rows):
            walks.setdefault(walk_of(jobs[w]), []).append(w)
        self.groups: list[tuple[np.ndarray, ClosedLoops]] = []
        for worlds in walks.values():
            loops = ClosedLoops(
                [robots[w] for w in worlds], [jobs[w] for w in worlds],
                [starts[w] for w in worlds], steps, np.stack([first_rows[w] for w in worlds]),
            )  # fmt: skip
            self.groups.append((np.array(worlds), loops))

    def __bool__(self) -> bool:
        return bool(self.groups)

    def plan(self, first: int, counting: np.ndarray, out: np.ndarray) -> None:
        """Frame `first`'s ctrl of every counting closed-loop world into its rows of `out`
        (worlds, steps, nu)."""
        for worlds, loops in self._counting(counting):
            out[worlds] = loops.plan(first, None)

    def record(self, rows: np.ndarray, counting: np.ndarray) -> None:
        """The sensordata after each step of the frame just stepped, (worlds, steps, ns)."""
        for worlds, loops in self._counting(counting):
            loops.record(rows[worlds])

    def _counting(self, counting: np.ndarray) -> list[tuple[np.ndarray, ClosedLoops]]:
        """The groups' counting worlds, each group left by the worlds that stopped counting."""
        for g, (worlds, loops) in enumerate(self.groups):
            still = counting[worlds]
            if not still.all() and still.any():
                loops.keep(still)
            self.groups[g] = (worlds[still], loops)
        return [(worlds, loops) for worlds, loops in self.groups if len(worlds)]


class WorldEnds:
    """A batch's worlds as they end, in the calling process: every frame's end (`qpos` and
    `sensors`, (n_frames, worlds, ...) float32, written by the caller; in shared memory when
    the call has a pool) tested as the lanes test them (`test`: a world that fell or blew up
    stops counting), the worlds that ended measured (`measure`: `measure_world`, on `pool`
    when there is one, which reads their frames from the shared memory), their results handed
    on in job order (`ready`). `release` on every path."""

    def __init__(
        self,
        robot: RobotModel,
        jobs: Sequence[Job],
        starts: Sequence[Start],
        n_frames: int,
        pool: HostPool | None,
        notice: Callable[[str], None] | None = None,
    ) -> None:
        self.robot, self.jobs, self.starts, self.n_frames = robot, jobs, starts, n_frames
        model, worlds = robot.model, len(jobs)
        shapes = ((n_frames, worlds, model.nq), (n_frames, worlds, model.nsensordata))
        nbytes = sum(math.prod(shape) * 4 for shape in shapes)
        what, instead = "the batch's frame ends", "the worlds are measured in this process"
        short = None if pool is None else shared_memory_short(nbytes, what, instead)
        if short is not None and notice is not None:
            notice(short)
        self.pool = pool if short is None else None
        shared = self.pool is not None
        self._ends = (HostArray(shapes[0], shared=shared), HostArray(shapes[1], shared=shared))
        self.qpos, self.sensors = (ends.array for ends in self._ends)
        self._heights = np.array([start.standing_height_m for start in starts])
        #: the worlds still counting, and the frames each counts (to its fall)
        self.counting = np.ones(worlds, bool)
        self.counted = np.full(worlds, n_frames)
        self._measured: list[Measured | None] = [None] * worlds
        self._handed = 0

    def release(self) -> None:
        """The frame ends let go of (shared memory unlinked). Safe to call twice."""
        self.qpos = self.sensors = np.empty((0, 0, 0), np.float32)
        for ends in self._ends:
            ends.release()

    def test(self, first: int, frames: int) -> None:
        """Frames first.. (`frames` of them; the last segment ends every world) of the worlds
        still counting tested, all worlds at once with the lanes' arithmetic: a world whose
        frame end blew up or fell counts to that frame and stops counting."""
        part, counting = slice(first, first + frames), np.flatnonzero(self.counting)
        if counting.size and frames:
            q = self.qpos[part][:, counting].astype(np.float64)  # (frames, counting, nq)
            ended = not_finite(q) | has_fallen(q, self._heights[counting])
            fell = ended.any(axis=0)
            self.counted[counting[fell]] = first + np.argmax(ended[:, fell], axis=0) + 1
            self.counting[counting[fell]] = False
        if first + frames >= self.n_frames:
            self.counting[:] = False

    def measure(self, warmup_s: float, with_traces: bool) -> None:
        """The worlds that ended and are not measured yet measured from their first `counted`
        frames."""
        ended = [int(w) for w in np.flatnonzero(~self.counting) if self._measured[w] is None]
        if not ended:
            return
        now: list[tuple[RunMetrics, Trace | None]]
        if self.pool is None:
            now = [
                measure_world(
                    self.robot,
                    self.jobs[w],
                    self.starts[w],
                    self.qpos[: self.counted[w], w],
                    self.sensors[: self.counted[w], w],
                    warmup_s,
                )
                for w in ended
            ]
        else:
            items = [(self.jobs[w], self.starts[w], w, int(self.counted[w])) for w in ended]
            now = self.pool.measure(self._ends, items, warmup_s, with_traces)
        for w, result in zip(ended, now, strict=True):
            self._measured[w] = result

    def ready(self) -> Iterator[tuple[int, RunMetrics, Trace | None]]:
        """(job index, metrics, trace) of each world measured and not yet handed on whose
        every earlier world was, in job order."""
        while self._handed < len(self._measured):
            measured = self._measured[self._handed]
            if measured is None:
                return
            self._handed += 1
            yield self._handed - 1, *measured
