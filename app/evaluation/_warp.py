"""The evaluation API on MuJoCo Warp (`WarpEvaluator`, docs/DESIGN.md §9, docs/GPU.md): a call's
runs are the worlds of one float32 batch on a CUDA device or Warp's CPU device, planned and
measured by the lanes' functions (over host processes: `_warp_pool.py`), controls uploaded per
segment. The `gpu` extra."""

from __future__ import annotations

import math
import os
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from app.evaluation._api import Cancelled, ExecutorError, Job, OnResult, Progress
from app.evaluation._frames import Push
from app.evaluation._warp_host import POOL_MIN_WORLDS, Planned, WorldEnds, plan_batch
from app.evaluation._warp_kernels import control_kernels
from app.evaluation._warp_model import batch_model, per_world_fields
from app.evaluation._warp_pool import HostPool
from app.robots.model import RobotModel
from app.sim.metrics import RunMetrics, Trace
from app.sim.planning import FRAME_S, frame_steps

#: `device=` (and "cuda:N")
DEVICES = ("cpu", "cuda")

GPU_EXTRA = 'pip install "artro-gait-studio[gpu]"'
#: frames per upload of controls and download of frame ends, fewer when the controls of a
#: segment would pass CONTROL_BYTES (float32, steps x worlds x actuators)
SEGMENT_FRAMES = 50
CONTROL_BYTES = 256 * 2**20
#: contacts per world on average (naconmax = worlds x this) and constraint rows per world: a
#: walking ArtRo makes <= 8 contacts and 44 rows, one lying on the floor 11 and 56 (CPU MuJoCo)
NCONMAX = 24
NJMAX = 96
#: the most a metric of a run here may differ from the lanes' on the same job, 2.5 s runs with
#: 1 s of warm-up (float32 against float64 physics; measured and argued in decision 0042 and
#: docs/GPU.md "Agreement"): `fell` and `blew_up` equal, `sim_s` and `fall_time_s` within
#: these; the motion metrics of runs that walked (a fall's are measured through the fall)
AGREEMENT = {
    "forward_cm_s": 0.2,
    "lateral_cm_s": 0.2,
    "turn_deg_s": 0.6,
    "predicted_turn_deg_s": 0.2,
    "path_error_cm": 0.15,
    "gyro_rms": 0.02,
    "feet_distance_cm": 0.08,
    "peak_torque_nm": 0.05,
    "at_limit_share": 0.02,
    "sim_s": 0.04,
    "fall_time_s": 0.04,
}
_SOLVER_LIMITS = 1 << 9 | 1 << 10  # OverflowType ITERATIONS, LS_ITERATIONS: not buffer overflows
_ANNOUNCED: set[str] = set()  # devices whose kernels this process said it compiles
_LOAD_LOCK = threading.Lock()


def import_warp() -> tuple[Any, Any]:
    """(warp, mujoco_warp), Warp's own messages kept off stdout; ExecutorError naming the extra
    to install when either is missing."""
    try:
        import warp as wp

        wp.config.log_level = wp.LOG_WARNING  # no banner, no "Module ... load" lines on stdout
        import mujoco_warp as mjw
    except ImportError as error:
        raise ExecutorError(
            f"--backend warp needs MuJoCo Warp, which is not installed ({error}): {GPU_EXTRA}"
        ) from None
    return wp, mjw


def cuda_present() -> bool:
    """True when the `gpu` extra is installed and Warp sees a CUDA device (`--backend auto`)."""
    try:
        wp, _mjw = import_warp()
    except ExecutorError:
        return False
    return wp.get_cuda_device_count() > 0


def warp_device(wp: Any, device: str) -> Any:
    """Warp's device for `device` ("cpu", "cuda" or "cuda:N"); ExecutorError when it is none of
    these or there is no such CUDA device."""
    if device == "cpu":
        return wp.get_device("cpu")
    if device == "cuda" or device.startswith("cuda:"):
        count = wp.get_cuda_device_count()
        if count == 0:
            raise ExecutorError(
                f"--device {device}: Warp finds no CUDA device on this machine; run with "
                "--device cpu (Warp's CPU device: slow, for checks) or --backend cpu"
            )
        try:
            return wp.get_device(device)
        except (RuntimeError, ValueError):
            raise ExecutorError(
                f"--device {device}: no such CUDA device; this machine has {count} "
                f"(cuda:0 to cuda:{count - 1})"
            ) from None
    raise ExecutorError(f"--device must be one of {', '.join(DEVICES)}, got {device!r}")


class WarpEvaluator:
    """Evaluates runs as the worlds of one MuJoCo Warp batch per call.

    Every job of a call is a world: per-world model values for the variations (`batch_model`;
    a field MuJoCo Warp cannot hold per world refuses the call, ExecutorError), the open-loop
    controls planned on the CPU as the lanes plan them and uploaded per segment, a push set on
    the trunk in its step. Falls are found per world at frame ends; a fallen or blown-up world
    stops counting (it keeps stepping with the others). Results are float32 physics: close to
    the lanes', not bit-equal (docs/GPU.md "Agreement"). With a feedback law on, the worlds'
    loops (`ClosedLoops`, the lanes' own, one per walk) plan each frame from the sensor rows
    of the steps before, a frame a segment; the CoP law, which reads the soles' force sensors,
    is refused (ExecutorError).

    Args:
        robot: the model (default: the built-in one).
        device: "cuda", "cuda:N" or "cpu" (Warp's CPU device: slow, for tests and checks).
        notice: told in a sentence, once per device and process, that the kernels are being
            compiled (None: nothing is said).
        segment_frames: frames per upload of controls and look at falls and `cancel`
            (fewer when the controls would pass CONTROL_BYTES).
        host_processes: processes that plan and measure the worlds (`HostPool`: spawned, the
            controls in shared memory, the same bits as one); default every core; 1 does it
            all in the calling process. Close the evaluator when done (`close`, or `with`).
        host_min_worlds: the fewest worlds a call has for the pool to plan and measure them
            (it starts with the first such call and is kept); fewer are done here.
    """

    def __init__(
        self,
        robot: RobotModel | None = None,
        *,
        device: str = "cuda",
        notice: Callable[[str], None] | None = None,
        segment_frames: int = SEGMENT_FRAMES,
        host_processes: int | None = None,
        host_min_worlds: int = POOL_MIN_WORLDS,
    ) -> None:
        if segment_frames < 1:
            raise ValueError(f"segment_frames must be at least 1, got {segment_frames}")
        processes = (os.cpu_count() or 1) if host_processes is None else host_processes
        if processes < 1:
            raise ValueError(f"host_processes must be at least 1, got {host_processes}")
        self._wp, self._mjw = import_warp()
        self.segment_frames = segment_frames
        self.device = warp_device(self._wp, device)
        self.robot = robot or RobotModel.load()
        self.model = self.robot.model
        self.steps_per_frame = frame_steps(self.model)
        self._notice = notice
        #: seconds the first batch's first step took here (kernels compiled or loaded from
        #: Warp's cache), None before it
        self.compile_s: float | None = None
        #: why a CUDA device steps frame by frame in Python instead of replaying one captured
        #: frame (a CUDA graph), None when it replays or the device is the CPU
        self.graph_error: str | None = None
        #: physics steps taken (worlds x steps) and seconds spent per stage since creation
        self.world_steps = 0
        self.stage_s = {"plan": 0.0, "laws": 0.0, "upload": 0.0, "step": 0.0, "measure": 0.0}
        self.host_processes, self.host_min_worlds = processes, host_min_worlds
        #: the worker processes of the host's work (None with one process)
        self.host_pool = HostPool(self.robot, processes) if processes > 1 else None

    def close(self) -> None:
        """The host's worker processes stopped (a later call starts new ones)."""
        if self.host_pool is not None:
            self.host_pool.close()

    def __enter__(self) -> WarpEvaluator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def evaluate(
        self,
        jobs: Sequence[Job],
        *,
        duration_s: float,
        warmup_s: float = 5.0,
        progress: Progress | None = None,
        traces: list[Trace] | None = None,
        cancel: threading.Event | None = None,
        on_result: OnResult | None = None,
    ) -> list[RunMetrics]:
        """Metrics of each job, in order (the `Evaluator` protocol). `cancel` is looked at
        between segments (Cancelled); `progress`, `on_result` and `traces` come in job order
        as worlds finish, in the calling thread. `wall_s` is a world's share of the batch's
        stepping time (the batch's seconds / worlds)."""
        for i, job in enumerate(jobs):
            if job.params.cop.enabled:
                raise ExecutorError(
                    f"job {i} has the CoP law on, which reads the soles' force sensors: the warp "
                    "backend does not model them; run it with --backend cpu"
                )
        if not jobs:
            return []
        if cancel is not None and cancel.is_set():
            raise Cancelled(f"cancelled after 0 of {len(jobs)} runs")
        n_frames = math.ceil(duration_s / FRAME_S - 1e-9)
        t0, pool = time.perf_counter(), self._pool_for(len(jobs))
        fields: dict[str, np.ndarray] = {}

        def read_fields(robots: list[RobotModel]) -> None:  # while the workers plan
            fields.update(per_world_fields([r.model for r in robots]))

        planned = plan_batch(
            self.robot, jobs, n_frames, self.steps_per_frame, pool, self._notice, read_fields
        )
        try:  # the controls may be shared memory: released on every path
            batch = _Batch(self, jobs, n_frames, planned, fields, pool)
            self.stage_s["plan"] += time.perf_counter() - t0
            return batch.run(warmup_s, progress, traces, cancel, on_result)
        finally:
            planned.controls.release()

    def _pool_for(self, worlds: int) -> HostPool | None:
        """The pool that plans and measures a call of `worlds` worlds, None to do it here."""
        return self.host_pool if worlds >= self.host_min_worlds else None

    def _announce(self) -> None:
        """Say once per device and process that the kernels compile (Warp caches them)."""
        key = str(self.device)
        with _LOAD_LOCK:
            if key in _ANNOUNCED:
                return
            _ANNOUNCED.add(key)
        if self._notice is not None:
            self._notice(
                f"warp: compiling MuJoCo Warp's kernels for device {key} unless cached in "
                f"{self._wp.config.kernel_cache_dir} (about a minute from an empty cache on a "
                "CPU; kept there for later runs)"
            )


@dataclass
class _Flight:
    """A segment sent to the device (`_Batch._launch`) and not yet collected."""

    first: int
    frames: int
    #: each frame's end qpos and sensordata on the device (frames, worlds, ...)
    ends_q: Any
    ends_s: Any
    #: the host's seconds launching it; the device's events around its steps (CUDA only)
    host_s: float = 0.0
    began: Any = None
    ended: Any = None


class _Batch:
    """One call's worlds as planned (`plan_batch`): put on the device, stepped segment by
    segment, measured (`WorldEnds`: on `pool` when the call has one).

    The host's work overlaps the device's: once a segment's frame ends are read back and
    tested, the next segment goes up and is launched, and only then are the worlds that ended
    measured and the following segment's controls copied out, while the device steps. On a
    CUDA device the controls go up from page-locked memory."""

    def __init__(
        self,
        owner: WarpEvaluator,
        jobs: Sequence[Job],
        n_frames: int,
        planned: Planned,
        fields: dict[str, np.ndarray],
        pool: HostPool | None,
    ) -> None:
        self.owner, self.jobs, self.n_frames, self.pool = owner, jobs, n_frames, pool
        self.robots, self.starts, self.loops = planned.robots, planned.starts, planned.loops
        #: every world's ctrl of every step, float32 (worlds, steps, nu): a world's rows in one
        #: block, so a segment's controls go up as one contiguous slice per world
        self.controls, self.initial, self.fields = planned.controls, planned.initial, fields
        self.pushes = [Push(r, j) for r, j in zip(self.robots, jobs, strict=True)]
        self.closed = bool(self.loops)  # a law on in some world
        #: the last upload's end on a CUDA device (the host's buffer is reused after it)
        self.uploaded: Any = None

    def run(
        self,
        warmup_s: float,
        progress: Progress | None,
        traces: list[Trace] | None,
        cancel: threading.Event | None,
        on_result: OnResult | None,
    ) -> list[RunMetrics]:
        """Step segment by segment until every world fell or ran its frames, `cancel` looked
        at between segments; results and callbacks in job order as worlds finish."""
        batch, data = self._put()
        ends = WorldEnds(
            self.owner.robot, self.jobs, self.starts, self.n_frames, self.pool, self.owner._notice
        )
        try:  # each segment launched before the one before it is measured
            worlds = len(self.jobs)
            results: list[RunMetrics] = []
            step_s = 0.0
            if cancel is not None and cancel.is_set():
                raise Cancelled(f"cancelled after 0 of {worlds} runs")
            self._stage(0)
            flight = self._launch(batch, data, 0, ends.counting)
            self._stage(flight.frames)  # the next segment's rows, while the device steps
            while flight is not None:
                first, frames = flight.first, flight.frames
                part = slice(first, first + frames)
                step_s += self._collect(
                    data, flight, ends.qpos[part], ends.sensors[part], ends.counting
                )
                t0 = time.perf_counter()
                ends.test(first, frames)
                self.owner.stage_s["measure"] += time.perf_counter() - t0
                done, flight = first + frames, None
                if done < self.n_frames and ends.counting.any():
                    if cancel is not None and cancel.is_set():
                        raise Cancelled(f"cancelled after {len(results)} of {worlds} runs")
                    flight = self._launch(batch, data, done, ends.counting)
                t0 = time.perf_counter()
                ends.measure(warmup_s, traces is not None)  # while the device steps `flight`
                self.owner.stage_s["measure"] += time.perf_counter() - t0
                for index, metrics, trace in ends.ready():
                    metrics["wall_s"] = step_s / worlds
                    metrics["rtf"] = metrics["sim_s"] / metrics["wall_s"]
                    if on_result is not None:
                        on_result(index, metrics)
                    results.append(metrics)
                    if traces is not None and trace is not None:  # a trace comes when asked
                        traces.append(trace)
                    if progress is not None:
                        progress(len(results), worlds)
                if flight is None:
                    break
                if cancel is not None and cancel.is_set():  # the segment in flight is dropped
                    raise Cancelled(f"cancelled after {len(results)} of {worlds} runs")
                self._stage(flight.first + flight.frames)
            return results
        finally:  # a segment may still be in flight (Cancelled, an error): its upload reads
            self.owner._wp.synchronize_device(self.owner.device)  # the host's buffer, freed
            ends.release()  # with this batch

    def _put(self) -> tuple[Any, Any]:
        """The batch's model and data on the device, the segment's buffers made, a frame
        captured as a CUDA graph where it can be."""
        owner, wp, mjw = self.owner, self.owner._wp, self.owner._mjw
        worlds, steps, model = len(self.jobs), owner.steps_per_frame, owner.model
        t0 = time.perf_counter()
        batch = batch_model([r.model for r in self.robots], owner.device, self.fields)
        batch.opt.warn_overflow = 0  # read from `overflow` below, not printed by the device
        with wp.ScopedDevice(owner.device):
            data = mjw.make_data(model, nworld=worlds, nconmax=NCONMAX, njmax=NJMAX)
            for name, values in self.initial.items():
                if values.size:
                    getattr(data, name).assign(values.astype(np.float32))
        owner.stage_s["upload"] += time.perf_counter() - t0
        owner._announce()
        fit = CONTROL_BYTES // (steps * worlds * model.nu * 4)
        # the closed loop plans each frame from the sensors of the frame before: one a segment
        self.per_segment = 1 if self.closed else max(1, min(owner.segment_frames, fit))
        shape = (worlds, self.per_segment * steps, model.nu)
        with wp.ScopedDevice(owner.device):
            #: the segment's controls on the device (worlds, steps, nu), padded to a whole
            #: segment (one buffer for the whole call: a captured frame reads it), the row
            #: cursor, and the host's buffer they go up from (page-locked on a CUDA device)
            self.segment = wp.zeros(shape, dtype=float)
            self.cursor = wp.zeros(1, dtype=int)
            pinned = owner.device.is_cuda
            self.host_buffer = wp.zeros(shape, dtype=float, device="cpu", pinned=pinned)
            self.host_segment = self.host_buffer.numpy()
            rows_shape = (worlds, self.per_segment * steps, model.nsensordata)
            #: each step's sensordata, for the closed loop's sensors (None when open)
            self.step_rows = wp.zeros(rows_shape, dtype=float) if self.closed else None
        self.graph = self._capture(batch, data) if owner.device.is_cuda else None
        return batch, data

    def _stage(self, first: int) -> None:
        """The open-loop controls of the segment from frame `first` into the host's buffer,
        once the last upload from it has ended."""
        owner = self.owner
        t0 = time.perf_counter()
        frames = min(self.per_segment, self.n_frames - first)
        if frames > 0:
            if self.uploaded is not None:
                owner._wp.synchronize_event(self.uploaded)
            rows = slice(first * owner.steps_per_frame, (first + frames) * owner.steps_per_frame)
            self.host_segment[:, : rows.stop - rows.start] = self.controls.array[:, rows]
        owner.stage_s["upload"] += time.perf_counter() - t0

    def _launch(self, batch: Any, data: Any, first: int, counting: np.ndarray) -> _Flight:
        """The segment from frame `first` (its open-loop controls `_stage`d) sent: a
        closed-loop world's frame planned from its sensors so far, the controls uploaded, the
        frames launched and their ends copied on the device. Returns at once on a CUDA device
        (the device steps on); `_collect` waits for it."""
        owner, wp = self.owner, self.owner._wp
        worlds, steps = len(self.jobs), owner.steps_per_frame
        nq, ns = owner.model.nq, owner.model.nsensordata
        frames = min(self.per_segment, self.n_frames - first)
        t0 = time.perf_counter()
        self.loops.plan(first, counting, self.host_segment[:, :steps])
        t1 = time.perf_counter()
        owner.stage_s["laws"] += t1 - t0
        rows = slice(first * steps, (first + frames) * steps)
        pushes = self._pushes(rows)
        with wp.ScopedDevice(owner.device):
            wp.copy(self.segment, self.host_buffer)
            if owner.device.is_cuda:
                self.uploaded = wp.record_event()
            self.cursor.zero_()
            flight = _Flight(
                first,
                frames,
                wp.empty((frames, worlds, nq), dtype=float),
                wp.empty((frames, worlds, ns), dtype=float),
            )
            t_up = time.perf_counter()
            if owner.device.is_cuda:
                flight.began = wp.record_event(wp.Event(enable_timing=True))
            for f in range(frames):
                first_step = rows.start + f * steps
                pushed = any(first_step + k in pushes for k in range(steps))
                if self.graph is not None and not pushed:
                    wp.capture_launch(self.graph)
                else:
                    self._steps_by_hand(batch, data, pushes, first_step, t_up)
                wp.copy(flight.ends_q, data.qpos, dest_offset=f * worlds * nq, count=worlds * nq)
                wp.copy(
                    flight.ends_s, data.sensordata, dest_offset=f * worlds * ns, count=worlds * ns
                )
            if owner.device.is_cuda:
                flight.ended = wp.record_event(wp.Event(enable_timing=True))
        t2 = time.perf_counter()
        owner.stage_s["upload"] += t_up - t1
        flight.host_s = t2 - t_up
        owner.world_steps += frames * steps * worlds
        return flight

    def _collect(
        self,
        data: Any,
        flight: _Flight,
        qpos_out: np.ndarray,
        sensors_out: np.ndarray,
        counting: np.ndarray,
    ) -> float:
        """The segment in `flight` waited for: each frame's end qpos and sensordata into the
        outputs (frames, worlds, ...), a closed-loop world's step rows recorded. Returns its
        stepping seconds (the device's, timed by events on a CUDA device); ExecutorError when
        a world still `counting` overflowed the contact or constraint buffers."""
        owner, wp = self.owner, self.owner._wp
        t0 = time.perf_counter()
        with wp.ScopedDevice(owner.device):
            qpos_out[:] = flight.ends_q.numpy()
            sensors_out[:] = flight.ends_s.numpy()
            step_rows = self.step_rows.numpy() if self.step_rows is not None else None
            overflow = np.where(counting, data.overflow.numpy() & ~_SOLVER_LIMITS, 0)
        t1 = time.perf_counter()
        if flight.began is not None:
            step_s = wp.get_event_elapsed_time(flight.began, flight.ended) / 1000.0
        else:
            step_s = flight.host_s + t1 - t0
        owner.stage_s["step"] += step_s
        if step_rows is not None:
            steps = owner.steps_per_frame
            self.loops.record(step_rows[:, :steps].astype(np.float64), counting)
            owner.stage_s["laws"] += time.perf_counter() - t1
        if overflow.any():
            w = int(np.argmax(overflow != 0))
            first, last = flight.first, flight.first + flight.frames - 1
            raise ExecutorError(
                f"world {w} (job {w}) overflowed MuJoCo Warp's contact or constraint buffers "
                f"(OverflowType {int(overflow[w])}) in frames {first}..{last}; "
                "run these jobs with --backend cpu"
            )
        return step_s

    def _steps_by_hand(
        self, batch: Any, data: Any, pushes: dict[int, np.ndarray], first_step: int, t1: float
    ) -> None:
        """One frame stepped from Python, a push set in its step: on the CPU device, and on a
        CUDA device where no captured frame replays or a push acts."""
        owner, wp, mjw = self.owner, self.owner._wp, self.owner._mjw
        for k in range(owner.steps_per_frame):
            self._feed(data)
            push = pushes.get(first_step + k)
            if push is not None:
                data.xfrc_applied.assign(push)
            mjw.step(batch, data)
            self._keep(data)
            if owner.compile_s is None:  # the kernels compile (or load) in the first step
                wp.synchronize_device(owner.device)
                owner.compile_s = time.perf_counter() - t1
            if push is not None:
                data.xfrc_applied.zero_()

    def _feed(self, data: Any) -> None:
        """The cursor's row of the segment's controls into `d.ctrl`, the cursor moved on."""
        wp, kernels = self.owner._wp, control_kernels()
        worlds, nu = len(self.jobs), self.owner.model.nu
        wp.launch(kernels.set_ctrl, (worlds, nu), inputs=[self.segment, self.cursor, data.ctrl])
        wp.launch(kernels.advance, 1, inputs=[self.cursor])

    def _keep(self, data: Any) -> None:
        """The step's sensordata into the segment's rows, where a closed loop reads them."""
        if self.step_rows is not None:
            wp, worlds = self.owner._wp, len(self.jobs)
            shape = (worlds, self.owner.model.nsensordata)
            keep = control_kernels().keep_row
            wp.launch(keep, shape, inputs=[data.sensordata, self.cursor, self.step_rows])

    def _capture(self, batch: Any, data: Any) -> Any:
        """One frame's steps (`_feed`, then `step`) captured as a CUDA graph, which a frame then
        replays with one launch instead of some hundred kernel launches per step from Python;
        its capture loads (or compiles) every kernel module (`compile_s`). None, the reason in
        `graph_error`, where capture fails: the frames are then stepped by hand, slower, with
        the same results."""
        owner, wp, mjw = self.owner, self.owner._wp, self.owner._mjw
        t0 = time.perf_counter()
        with wp.ScopedDevice(owner.device):
            try:
                with wp.ScopedCapture() as capture:
                    for _ in range(owner.steps_per_frame):
                        self._feed(data)
                        mjw.step(batch, data)
                        self._keep(data)
            except Exception as error:  # any failure to capture: stepped by hand
                owner.graph_error = f"{type(error).__name__}: {error}"
                return None
            finally:
                owner.stage_s["step"] += time.perf_counter() - t0
        if owner.compile_s is None:
            owner.compile_s = time.perf_counter() - t0
        owner.graph_error = None
        return capture.graph

    def _pushes(self, rows: slice) -> dict[int, np.ndarray]:
        """xfrc_applied of every world (worlds, nbody, 6) for each step in `rows` a push acts in."""
        out: dict[int, np.ndarray] = {}
        nbody = self.owner.model.nbody
        for w, push in enumerate(self.pushes):
            if rows.start <= push.step < rows.stop:
                xfrc = out.setdefault(push.step, np.zeros((len(self.pushes), nbody, 6), np.float32))
                xfrc[w, push.trunk, :3] = push.force
        return out
