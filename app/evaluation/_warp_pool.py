"""A MuJoCo Warp batch's work per world on the host: each world's start and controls planned
(`plan_worlds`), each finished world measured (`measure_world`), in the calling process or over
`HostPool`'s spawned workers, which write the controls into shared memory (`HostArray`), to
the same bits either way. No Warp here: the workers never load it."""

from __future__ import annotations

import ctypes
import json
import math
import multiprocessing
import os
import secrets
import shutil
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from functools import lru_cache
from multiprocessing.shared_memory import SharedMemory
from typing import Any

import mujoco
import numpy as np

from app.evaluation._api import Job
from app.evaluation._frames import STATE_SPEC, Start
from app.evaluation._measure import fallen, measure_frames, not_finite
from app.evaluation._open_loop import plan_open_loop
from app.evaluation._processes import WorkerDied
from app.robots import parse_description
from app.robots.model import RobotModel
from app.sim.metrics import RunMetrics, Trace
from app.worlds.variations import Variation, varied_robot
from gait import feedback

#: tasks per worker process and call, so that a worker slowed by other work is waited on less
CHUNKS_PER_PROCESS = 4
#: the start of the names of the batches' shared memory (/dev/shm/artro-warp-PID-TOKEN on Linux)
SHM_PREFIX = "artro-warp-"
#: what a world starts from in the batch: these rows of MjData after the start state is set
INITIAL = ("qpos", "qvel", "act", "ctrl")
#: one world's metrics and trace (None where the caller asked for no traces)
Measured = tuple[RunMetrics, Trace | None]
#: glibc's mallopt parameters and a worker's values (`_worker_start`): arrays up to 32 MiB from
#: the heap, and up to 256 MiB of freed heap kept rather than given back to the kernel
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
_WORKER_MALLOPT = {_M_MMAP_THRESHOLD: 32 * 2**20, _M_TRIM_THRESHOLD: 256 * 2**20}


def varied_robots(
    robot: RobotModel, jobs: Sequence[Job], varied: dict[Variation, RobotModel]
) -> list[RobotModel]:
    """Each job's robot as its variation's physics varies it, one per distinct variation, kept
    in `varied` (a varied model is ~2.6 ms to make, shared by the variation's every case). A
    variation's physics (a new, checked Variation each time it is asked for) is asked once
    per Variation object: a study's cases share theirs."""
    physics_of: dict[int, Variation] = {}
    out: list[RobotModel] = []
    for job in jobs:
        physics = physics_of.get(id(job.variation))
        if physics is None:
            physics = physics_of[id(job.variation)] = job.variation.physics
        world = varied.get(physics)
        if world is None:
            world = varied[physics] = robot if physics.is_nominal else varied_robot(robot, physics)
        out.append(world)
    return out


def initial_arrays(model: mujoco.MjModel, worlds: int) -> dict[str, np.ndarray]:
    """Empty rows of `INITIAL` for `worlds` worlds of `model` (float64, as MjData holds them)."""
    sizes = {"qpos": model.nq, "qvel": model.nv, "act": model.na, "ctrl": model.nu}
    return {name: np.empty((worlds, sizes[name])) for name in INITIAL}


def plan_worlds(
    robots: Sequence[RobotModel],
    jobs: Sequence[Job],
    n_frames: int,
    control: np.ndarray,
    initial: dict[str, np.ndarray],
    plans: dict[tuple, Any],
    data: mujoco.MjData,
) -> tuple[list[Start], dict[int, np.ndarray]]:
    """Each world's start and the ctrl of its every step (`plan_open_loop`, cast to `control`'s
    float32 by assignment), written into row w of `control` (worlds, steps, nu) and `initial`;
    `data` is the scratch, `plans` the gait plans kept by case. Returns the starts and, for
    the worlds with a law on, the sensordata standing at the start (what `ClosedLoops` reads
    first), by world."""
    starts: list[Start] = []
    first_rows: dict[int, np.ndarray] = {}
    for w, (world, job) in enumerate(zip(robots, jobs, strict=True)):
        start, control[w] = plan_open_loop(world, job, n_frames, data, plans)
        mujoco.mj_setState(world.model, data, start.state, STATE_SPEC)
        for name in ("qpos", "qvel", "act"):
            initial[name][w] = getattr(data, name)
        initial["ctrl"][w] = start.ctrl
        starts.append(start)
        if feedback.any_law_on(job.params):
            first_rows[w] = data.sensordata.copy()
    return starts, first_rows


def measure_world(
    robot: RobotModel,
    job: Job,
    start: Start,
    qpos: np.ndarray,
    sensors: np.ndarray,
    warmup_s: float,
) -> tuple[RunMetrics, Trace]:
    """A world's metrics and trunk trace from its frame ends as the device gave them, `qpos`
    (frames, nq) and `sensors` (frames, nsensordata) float32, measured as the lanes measure a
    run (`measure_frames`), in float64."""
    q = qpos.astype(np.float64)
    bad, down = not_finite(q), fallen(q, start)
    return measure_frames(robot, job, q, sensors.astype(np.float64), bad, down, warmup_s)


class HostArray:
    """A batch's large host array, `array` of `shape` and `dtype` (the controls of every step,
    worlds x steps x nu float32, GBs for a large study; the frame ends): in this process's
    memory, or with `shared` in POSIX shared memory (named SHM_PREFIX...), which the pool's
    workers open by `name` to write or read it, so that the array is never pickled. `release`
    unlinks and unmaps the shared memory: call it on every path, and keep no view of `array`
    past it (its pages are gone)."""

    def __init__(self, shape: tuple[int, ...], dtype: Any = np.float32, *, shared: bool) -> None:
        self._shm: SharedMemory | None = None
        self.dtype = np.dtype(dtype)
        if not shared:
            self.array = np.empty(shape, self.dtype)
            return
        name = f"{SHM_PREFIX}{os.getpid()}-{secrets.token_hex(4)}"
        size = max(1, math.prod(shape) * self.dtype.itemsize)  # 0 bytes cannot be made
        self._shm = SharedMemory(name=name, create=True, size=size)
        self.array = np.ndarray(shape, self.dtype, buffer=self._shm.buf)

    @property
    def name(self) -> str | None:
        """The shared memory's name (None when the array is private)."""
        return None if self._shm is None else self._shm.name

    def release(self) -> None:
        """The array let go of (an empty one in its place); shared memory unlinked (its name
        gone at once, its pages when the last process maps it no more). Safe to call twice."""
        self.array = np.empty((0,) * self.array.ndim, self.dtype)
        shm, self._shm = self._shm, None
        if shm is not None:
            shm.unlink()
            _close(shm)


def shared_memory_short(
    nbytes: int,
    what: str = "the batch's controls",
    instead: str = "they are planned in this process, not over the host processes",
) -> str | None:
    """Why `nbytes` of `what` cannot go into shared memory here (and so `instead`), or None
    when they fit: a /dev/shm smaller than them (a container's default is 64 MiB) would kill
    the writing process with SIGBUS instead of refusing."""
    try:
        free = shutil.disk_usage("/dev/shm").free
    except OSError:
        return None  # no /dev/shm to measure (not Linux): trust the system's shared memory
    if free >= nbytes:
        return None
    return (
        f"warp: {what} ({nbytes / 2**30:.1f} GiB) do not fit in /dev/shm "
        f"({free / 2**30:.1f} GiB free), so {instead}"
    )


def _close(shm: SharedMemory) -> None:
    """Unmap `shm`; where a view of it is still alive (an exception's traceback holds one) the
    mapping goes with the view instead."""
    try:
        shm.close()
    except BufferError:
        pass


def chunks(count: int, processes: int) -> list[slice]:
    """`count` items cut into contiguous slices, CHUNKS_PER_PROCESS per process (fewer, never
    empty, for few items)."""
    size = max(1, math.ceil(count / max(1, min(count, processes * CHUNKS_PER_PROCESS))))
    return [slice(i, min(i + size, count)) for i in range(0, count, size)]


def _worker_start() -> None:
    """A worker's C heap keeps the arrays a world's planning makes and frees (its every step's
    ctrl in float64 is ~2 MB, made several times a world): with glibc's defaults they go back
    to the kernel and are faulted in again, ~280 page faults a world beside the ~235 of its
    controls in shared memory (measured on the 2-core VM: a worker's CPU 3.6 -> 3.2 ms a
    world). Nothing where the C library has no `mallopt`."""
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return
    for parameter, value in _WORKER_MALLOPT.items():
        mallopt(parameter, value)


@lru_cache(maxsize=4)
def _worker_robot(robot_json: str) -> RobotModel:
    """The robot described by `robot_json`, compiled once per worker process and robot."""
    return RobotModel.load(parse_description(json.loads(robot_json), "the robot sent"))


@lru_cache(maxsize=1)
def _call_plans(call: str) -> dict[tuple, Any]:
    """This worker's gait plans (one per case) for the batch `call`; the next call's replace
    them."""
    return {}


def plan_chunk(
    robot_json: str,
    call: str,
    first: int,
    jobs: list[Job],
    n_frames: int,
    shm_name: str,
    shape: tuple[int, int, int],
) -> tuple[list[Start], dict[str, np.ndarray], dict[int, np.ndarray]]:
    """A worker's task: worlds first.. of the batch `call` planned (`plan_worlds`), their
    controls written into the shared memory `shm_name` (the batch's whole array, `shape`).
    Returns their starts, `INITIAL` rows and closed-loop sensor rows (keys from 0)."""
    robot = _worker_robot(robot_json)
    plans = _call_plans(call)
    robots = varied_robots(robot, jobs, {})  # a chunk's variations: few, not kept
    initial = initial_arrays(robot.model, len(jobs))
    shm = SharedMemory(name=shm_name)
    try:
        control = np.ndarray(shape, np.float32, buffer=shm.buf)[first : first + len(jobs)]
        data = mujoco.MjData(robot.model)
        starts, first_rows = plan_worlds(robots, jobs, n_frames, control, initial, plans, data)
        del control
    finally:
        _close(shm)
    return starts, initial, first_rows


def measure_chunk(
    robot_json: str,
    ends: tuple[str, tuple[int, ...], str, tuple[int, ...]],
    items: list[tuple[Job, Start, int, int]],
    warmup_s: float,
    with_traces: bool,
) -> list[Measured]:
    """A worker's task: each (job, start, world, frames) measured (`measure_world`) from its
    first `frames` frame ends in the batch's shared memory `ends` (the qpos array's name and
    shape, then the sensors'), with its trace when asked."""
    robot = _worker_robot(robot_json)
    q_name, q_shape, s_name, s_shape = ends
    q_shm, s_shm = SharedMemory(name=q_name), SharedMemory(name=s_name)
    out: list[Measured] = []
    try:
        qpos = np.ndarray(q_shape, np.float32, buffer=q_shm.buf)
        sensors = np.ndarray(s_shape, np.float32, buffer=s_shm.buf)
        for job, start, w, n in items:
            metrics, trace = measure_world(robot, job, start, qpos[:n, w], sensors[:n, w], warmup_s)
            out.append((metrics, trace if with_traces else None))
        del qpos, sensors
    finally:
        _close(q_shm)
        _close(s_shm)
    return out


class HostPool:
    """`processes` spawned worker processes (no CUDA or Warp state is forked; a worker compiles
    the robot from its description once) that plan and measure a batch's worlds in contiguous
    chunks, results in order. Started by the first task, kept until `close`. A worker that
    dies raises WorkerDied, and the next call starts new ones."""

    def __init__(self, robot: RobotModel, processes: int) -> None:
        self.processes = processes
        self._robot_json = json.dumps(robot.description.model_dump(mode="json"), sort_keys=True)
        self._executor: ProcessPoolExecutor | None = None

    @property
    def started(self) -> bool:
        return self._executor is not None

    def plan(
        self,
        jobs: Sequence[Job],
        n_frames: int,
        controls: HostArray,
        initial: dict[str, np.ndarray],
        meanwhile: Callable[[], None] | None = None,
    ) -> tuple[list[Start], dict[int, np.ndarray]]:
        """`plan_worlds` of every job over the workers: the controls into `controls` (shared),
        `initial`'s rows filled; `meanwhile` runs here while the workers plan. Returns the
        starts and the closed-loop worlds' sensor rows, by world."""
        if controls.name is None:
            raise ValueError(
                "the pool's workers write into shared controls: HostArray(shared=True)"
            )
        call, parts = secrets.token_hex(8), chunks(len(jobs), self.processes)
        shape = controls.array.shape
        tasks = [
            (self._robot_json, call, part.start, list(jobs[part]), n_frames, controls.name, shape)
            for part in parts
        ]
        starts: list[Start] = []
        first_rows: dict[int, np.ndarray] = {}
        for part, (chunk_starts, chunk_initial, chunk_rows) in zip(
            parts, self._run(plan_chunk, tasks, "planning", meanwhile), strict=True
        ):
            starts += chunk_starts
            for name, rows in chunk_initial.items():
                initial[name][part] = rows
            first_rows |= {part.start + w: row for w, row in chunk_rows.items()}
        return starts, first_rows

    def measure(
        self,
        ends: tuple[HostArray, HostArray],
        items: Sequence[tuple[Job, Start, int, int]],
        warmup_s: float,
        with_traces: bool,
    ) -> list[Measured]:
        """`measure_world` of each (job, start, world, frames) over the workers, in order, from
        the frame ends `ends` (qpos and sensors, (frames, worlds, ...) float32, shared)."""
        qpos, sensors = ends
        if qpos.name is None or sensors.name is None:
            raise ValueError("the pool's workers read shared frame ends: HostArray(shared=True)")
        names = (qpos.name, qpos.array.shape, sensors.name, sensors.array.shape)
        tasks = [
            (self._robot_json, names, list(items[part]), warmup_s, with_traces)
            for part in chunks(len(items), self.processes)
        ]
        return [m for chunk in self._run(measure_chunk, tasks, "measuring") for m in chunk]

    def close(self) -> None:
        """The workers stopped (those busy finish their task first)."""
        executor, self._executor = self._executor, None
        if executor is not None:
            executor.shutdown(wait=True, cancel_futures=True)

    def _run(
        self,
        task: Callable[..., Any],
        tasks: list[tuple],
        what: str,
        meanwhile: Callable[[], None] | None = None,
    ) -> list[Any]:
        """Each task's result in order, `meanwhile` run here once they are submitted. A task's
        own error is raised as it is; WorkerDied where a worker process ended, the pool then
        dropped. On any error the tasks not yet started are cancelled."""
        if self._executor is None:
            spawn = multiprocessing.get_context("spawn")
            self._executor = ProcessPoolExecutor(
                self.processes, mp_context=spawn, initializer=_worker_start
            )
        futures: list[Future] = []
        try:
            futures += [self._executor.submit(task, *args) for args in tasks]
            if meanwhile is not None:
                meanwhile()
            return [future.result() for future in futures]
        except BrokenProcessPool as error:
            self._executor.shutdown(wait=False, cancel_futures=True)
            self._executor = None
            raise WorkerDied(
                f"a host worker process of the Warp batch ended while {what} {len(tasks)} "
                f"chunks ({error}); this call has no results, the next call starts new workers"
            ) from error
        finally:
            for future in futures:
                future.cancel()
