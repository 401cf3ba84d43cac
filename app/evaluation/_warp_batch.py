"""One `WarpEvaluator` call's worlds on the device (`Batch`, docs/GPU.md "Speed"): put once,
stepped segment by segment with the host's work overlapping the device's, frame ends read back
and tested, the worlds that ended measured (`WorldEnds`)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from app.evaluation._api import Cancelled, ExecutorError, Job, OnResult, Progress
from app.evaluation._frames import Push
from app.evaluation._warp_host import Planned, WorldEnds
from app.evaluation._warp_kernels import control_kernels
from app.evaluation._warp_model import batch_model
from app.evaluation._warp_pool import HostPool
from app.robots.model import RobotModel
from app.sim.metrics import RunMetrics, Trace

#: the controls of a segment go up in at most this many bytes (float32, steps x worlds x
#: actuators): fewer frames than the evaluator's segment when they would pass it
CONTROL_BYTES = 256 * 2**20
#: contacts per world on average (naconmax = worlds x this) and constraint rows per world: a
#: walking ArtRo makes <= 8 contacts and 44 rows, one lying on the floor 11 and 56 (CPU MuJoCo)
NCONMAX = 24
NJMAX = 96
_SOLVER_LIMITS = 1 << 9 | 1 << 10  # OverflowType ITERATIONS, LS_ITERATIONS: not buffer overflows


class BatchOwner(Protocol):
    """What a batch reads off its evaluator (`WarpEvaluator`), and the figures it adds to."""

    wp: Any  # the warp module
    mjw: Any  # the mujoco_warp module
    device: Any
    robot: RobotModel
    model: Any  # the robot's MjModel
    steps_per_frame: int
    segment_frames: int
    notice: Callable[[str], None] | None
    compile_s: float | None
    graph_error: str | None
    world_steps: int
    stage_s: dict[str, float]

    def announce(self) -> None: ...


@dataclass
class Flight:
    """A segment sent to the device (`Batch._launch`) and not yet collected."""

    first: int
    frames: int
    #: each frame's end qpos and sensordata on the device (frames, worlds, ...)
    ends_q: Any
    ends_s: Any
    #: the host's seconds launching it; the device's events around its steps (CUDA only)
    host_s: float = 0.0
    began: Any = None
    ended: Any = None


class Batch:
    """One call's worlds as planned (`plan_batch`): put on the device, stepped segment by
    segment, measured (`WorldEnds`: on `pool` when the call has one).

    The host's work overlaps the device's: once a segment's frame ends are read back and
    tested, the next segment goes up and is launched, and only then are the worlds that ended
    measured and the following segment's controls copied out, while the device steps. On a
    CUDA device the controls go up from page-locked memory."""

    def __init__(
        self,
        owner: BatchOwner,
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
            self.owner.robot, self.jobs, self.starts, self.n_frames, self.pool, self.owner.notice
        )
        try:  # each segment launched before the one before it is measured
            worlds = len(self.jobs)
            results: list[RunMetrics] = []
            step_s = 0.0
            if cancel is not None and cancel.is_set():
                raise Cancelled(f"cancelled after 0 of {worlds} runs")
            self._stage(0)
            flight: Flight | None
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
            self.owner.wp.synchronize_device(self.owner.device)  # the host's buffer, freed
            ends.release()  # with this batch

    def _put(self) -> tuple[Any, Any]:
        """The batch's model and data on the device, the segment's buffers made, a frame
        captured as a CUDA graph where it can be."""
        owner, wp, mjw = self.owner, self.owner.wp, self.owner.mjw
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
        owner.announce()
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
                owner.wp.synchronize_event(self.uploaded)
            rows = slice(first * owner.steps_per_frame, (first + frames) * owner.steps_per_frame)
            self.host_segment[:, : rows.stop - rows.start] = self.controls.array[:, rows]
        owner.stage_s["upload"] += time.perf_counter() - t0

    def _launch(self, batch: Any, data: Any, first: int, counting: np.ndarray) -> Flight:
        """The segment from frame `first` (its open-loop controls `_stage`d) sent: a
        closed-loop world's frame planned from its sensors so far, the controls uploaded, the
        frames launched and their ends copied on the device. Returns at once on a CUDA device
        (the device steps on); `_collect` waits for it."""
        owner, wp = self.owner, self.owner.wp
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
            flight = Flight(
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
        flight: Flight,
        qpos_out: np.ndarray,
        sensors_out: np.ndarray,
        counting: np.ndarray,
    ) -> float:
        """The segment in `flight` waited for: each frame's end qpos and sensordata into the
        outputs (frames, worlds, ...), a closed-loop world's step rows recorded. Returns its
        stepping seconds (the device's, timed by events on a CUDA device); ExecutorError when
        a world still `counting` overflowed the contact or constraint buffers."""
        owner, wp = self.owner, self.owner.wp
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
        owner, wp, mjw = self.owner, self.owner.wp, self.owner.mjw
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
        wp, kernels = self.owner.wp, control_kernels()
        worlds, nu = len(self.jobs), self.owner.model.nu
        wp.launch(kernels.set_ctrl, (worlds, nu), inputs=[self.segment, self.cursor, data.ctrl])
        wp.launch(kernels.advance, 1, inputs=[self.cursor])

    def _keep(self, data: Any) -> None:
        """The step's sensordata into the segment's rows, where a closed loop reads them."""
        if self.step_rows is not None:
            wp, worlds = self.owner.wp, len(self.jobs)
            shape = (worlds, self.owner.model.nsensordata)
            keep = control_kernels().keep_row
            wp.launch(keep, shape, inputs=[data.sensordata, self.cursor, self.step_rows])

    def _capture(self, batch: Any, data: Any) -> Any:
        """One frame's steps (`_feed`, then `step`) captured as a CUDA graph, which a frame then
        replays with one launch instead of some hundred kernel launches per step from Python;
        its capture loads (or compiles) every kernel module (`compile_s`). None, the reason in
        `graph_error`, where capture fails: the frames are then stepped by hand, slower, with
        the same results."""
        owner, wp, mjw = self.owner, self.owner.wp, self.owner.mjw
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
