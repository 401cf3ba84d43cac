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
from typing import Any

import numpy as np

from app.evaluation._api import Cancelled, ExecutorError, Job, OnResult, Progress
from app.evaluation._warp_batch import Batch
from app.evaluation._warp_host import POOL_MIN_WORLDS, plan_batch
from app.evaluation._warp_model import per_world_fields
from app.evaluation._warp_pool import HostPool
from app.robots.model import RobotModel
from app.sim.metrics import RunMetrics, Trace
from app.sim.planning import FRAME_S, frame_steps

#: `device=` (and "cuda:N")
DEVICES = ("cpu", "cuda")

#: how to install an extra where the package came from its folder (it is not on PyPI)
GPU_EXTRA = 'install the gpu extra: in the project\'s folder, pip install -e ".[gpu]"'
#: frames per upload of controls and download of frame ends, fewer when the controls of a
#: segment would pass `_warp_batch.CONTROL_BYTES`
SEGMENT_FRAMES = 50
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


def auto_choice(device: str | None, elsewhere: str | None = None) -> tuple[str, str, str]:
    """What `--backend auto` runs on: (backend, device, why in words). Warp on `device` where
    the gpu extra is installed and, for "cuda" (the default), Warp sees a CUDA device; else
    the CPU's executors ("cpu", ""). `elsewhere`: what sends the runs out of this process (a
    cluster, worker processes), where Warp cannot run."""
    if elsewhere:
        return "cpu", "", f"the CPU's executors, as {elsewhere} asks (Warp runs in this process)"
    try:
        wp, _mjw = import_warp()
    except ExecutorError:
        return "cpu", "", f"the CPU's executors: MuJoCo Warp is not installed ({GPU_EXTRA})"
    if device == "cpu":
        return "warp", "cpu", "MuJoCo Warp on Warp's CPU device, as --device cpu asks (slow)"
    wanted = device or "cuda"
    if wp.get_cuda_device_count() == 0:
        return "cpu", "", f"the CPU's executors: Warp finds no CUDA device ({wanted})"
    name = getattr(warp_device(wp, wanted), "name", "") or wanted
    return "warp", wanted, f"MuJoCo Warp on {wanted} ({name}): the gpu extra and a CUDA device"


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
        self.wp, self.mjw = import_warp()
        self.segment_frames = segment_frames
        self.device = warp_device(self.wp, device)
        self.robot = robot or RobotModel.load()
        self.model = self.robot.model
        self.steps_per_frame = frame_steps(self.model)
        self.notice = notice
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
            self.robot, jobs, n_frames, self.steps_per_frame, pool, self.notice, read_fields
        )
        try:  # the controls may be shared memory: released on every path
            batch = Batch(self, jobs, n_frames, planned, fields, pool)
            self.stage_s["plan"] += time.perf_counter() - t0
            return batch.run(warmup_s, progress, traces, cancel, on_result)
        finally:
            planned.controls.release()

    def _pool_for(self, worlds: int) -> HostPool | None:
        """The pool that plans and measures a call of `worlds` worlds, None to do it here."""
        return self.host_pool if worlds >= self.host_min_worlds else None

    def announce(self) -> None:
        """Say once per device and process that the kernels compile (Warp caches them)."""
        key = str(self.device)
        with _LOAD_LOCK:
            if key in _ANNOUNCED:
                return
            _ANNOUNCED.add(key)
        if self.notice is not None:
            self.notice(
                f"warp: compiling MuJoCo Warp's kernels for device {key} unless cached in "
                f"{self.wp.config.kernel_cache_dir} (about a minute from an empty cache on a "
                "CPU; kept there for later runs)"
            )
