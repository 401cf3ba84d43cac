"""The simulation thread of `artro serve`: paces the frame loop to the wall clock.

It alone owns the `FrameLoop` and its MjData (docs/DESIGN.md §10). Others send `Command`s,
change the parameter store, and read what it publishes: a `SimStatus` snapshot and body poses.
"""

from __future__ import annotations

import dataclasses
import enum
import logging
import math
import queue
import threading
import time
import traceback
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from app.firmware.emulator import EmulatorError
from app.robots.model import RobotModel
from app.server.firmware_driver import FIRMWARE_ENGINE, FirmwareDriver, FirmwareStatus
from app.server.gait_ramp import GAIT_RAMP_S, GaitRamp, gait_fields_changed
from app.server.ghost import Ghost, GhostStatus
from app.server.param_store import ParameterStore, Snapshot
from app.server.path_tracker import SAMPLE_EVERY_FRAMES, PathTracker
from app.server.recorder import Recorder
from app.server.robot_shelf import RobotShelf
from app.server.scope_feed import ScopeFeed
from app.sim.frame_loop import FRAME_S, START_PHASE_RAD, FrameLoop, FrameRecord
from app.sim.servo_load import ServoLoadMeter, ServoLoadReport
from app.worlds.variations import Variation
from gait import GaitParams
from hardware import HardwareSetup

log = logging.getLogger(__name__)

MAX_CATCHUP_FRAMES = 5  # at most 100 ms of simulated time is run back to back
RTF_WINDOW_S = 2.0
SPEED_RANGE = (0.25, 4.0)
BEHIND_SHOWN_S = 2.0  # "behind" stays set this long after frames were dropped
LOAD_PUBLISH_FRAMES = 25  # the servo load budget is published twice a second
GHOST_PUBLISH_FRAMES = 10  # the ghost's metrics five times a second
DRIVE_ANSWER_S = 10.0  # how long a drive switch waits for the simulation thread's verdict


class Command(enum.Enum):
    """What other threads may ask of the simulation thread."""

    PAUSE = "pause"
    RESUME = "resume"
    RESET = "reset"
    STEP = "step"  # one 20 ms frame, pausing first
    SPEED = "speed"  # value: x real time, within SPEED_RANGE
    REANCHOR = "reanchor"  # value: V in m/s fixed by hand, or None to measure it
    DRIVE = "drive"  # value: a DriveRequest (or a booted FirmwareDriver, or None: the model)
    GHOST = "ghost"  # value: (GaitParams, source label) of the A/B ghost, or None: no ghost
    WORLD = "world"  # value: the Variation the robot walks in (docs/DESIGN.md §8)


class Drive(enum.Enum):
    """Who makes the servo pulses: the Python hardware model, or the emulated firmware."""

    MODEL = "model"
    FIRMWARE = "firmware"


@dataclass
class DriveRequest:
    """A switch of the drive, answered by the simulation thread: `refused` says why not."""

    driver: FirmwareDriver | None  # booted, or None: the model
    answered: threading.Event = dataclasses.field(default_factory=threading.Event)
    refused: str | None = None


@dataclass(frozen=True)
class TrunkPose:
    x_m: float
    y_m: float
    z_m: float
    yaw_rad: float  # counter-clockwise


@dataclass(frozen=True)
class LatencySummary:
    """Frames from a change entering the store to the first frame built with it."""

    count: int = 0
    median: int | None = None
    max: int | None = None


@dataclass(frozen=True)
class SimStatus:
    """What the simulation thread published last; any thread may read it (immutable)."""

    sim_time_s: float = 0.0
    frame: int = 0
    rtf: float | None = None  # simulated / wall time over the last RTF_WINDOW_S, None: no window
    speed: float = 1.0
    paused: bool = False
    fell: bool = False
    behind: bool = False
    frames_dropped: int = 0
    trunk: TrunkPose = TrunkPose(0.0, 0.0, 0.0, 0.0)
    params_version_applied: int = 0
    param_latency_frames: LatencySummary = LatencySummary()
    resets: int = 0
    errors: tuple[str, ...] = ()
    drive: str = Drive.MODEL.value
    firmware: FirmwareStatus | None = None  # while the firmware drive is on
    gait_ramp: float | None = None  # how far a change of gait constants has come (0..1), if so
    world: str = "nominal"  # the variation the robot walks in, as `artro run --vary` takes it
    robot: str = ""  # the robot simulated (the store's version in use names it)

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self) | {"errors": list(self.errors)}


@dataclass(frozen=True)
class BodyPoses:
    """A copy of the bodies' world poses for the 3D view (never the live MjData)."""

    serial: int
    xpos: np.ndarray
    xmat: np.ndarray
    ghost_xpos: np.ndarray | None = None  # the A/B ghost's bodies, when there is one
    ghost_xmat: np.ndarray | None = None


class SimThread:
    def __init__(
        self,
        store: ParameterStore,
        *,
        robot: RobotModel | None = None,
        hardware: HardwareSetup | None = None,
        robots: Callable[[str], RobotModel] | None = None,
    ) -> None:
        """Simulate the store's sets on `robot` (default: the store's robot, built-in); a
        version that names another robot switches to `robots(name)` (default: built-ins)."""
        self.store = store
        robot = robot or RobotModel.load(store.robot)
        # the robot and model in use are replaced whole on a switch of robots, never changed:
        # any thread may read them
        self.robot = robot
        self._robots = robots or RobotShelf(robot).get
        self.hardware = hardware or robot.hardware()
        snap = store.snapshot()
        self._loop = FrameLoop(  # this thread's alone, with its MjData
            robot=robot, params=snap.gait, motion=snap.motion, hardware=self.hardware
        )
        self.model = self._loop.model  # immutable once loaded: any thread may read it
        self._firmware: FirmwareDriver | None = None  # the firmware drive, when on
        self._firmware_waited = 0  # frames the change in flight waited before it was sent
        self._ghost: Ghost | None = None  # the A/B ghost, this thread's alone
        self._gait_ramp: GaitRamp | None = None  # a change of gait constants on its way
        self._ghost_status: GhostStatus | None = None  # published
        self._load = ServoLoadMeter(self._loop.robot)  # the servo budget of the current gait
        self._load_report = self._load.report()
        self.scope = ScopeFeed(self.hardware.tdm)
        self.paths = PathTracker()
        self.recorder = Recorder(self.model.nq, _model_name(self.model))  # this thread writes
        self.recorder.keep_params(snap.version, snap.parameter_set().to_dict())
        self.paths.set_gait(snap.motion.ca, snap.gait.clock.freq_hz)
        self._commands: queue.SimpleQueue[tuple[Command, Any]] = queue.SimpleQueue()
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._applied = snap
        # (frames done, wall time) when the first not yet applied change entered the store
        self._pending: tuple[int, float] | None = None
        self._poses: BodyPoses | None = None
        self.publish_poses = False  # set by the 3D view, the only reader of body poses
        self._pose_serial = 0
        self.speed = 1.0
        self.paused = False
        self.frames_dropped = 0
        self.last_behind_wall = -math.inf
        self.errors: deque[str] = deque(maxlen=20)
        self.resets = 0
        # per applied change: frames from entering the store to the frame whose pulses carry it
        self.param_latency_frames: deque[int] = deque(maxlen=100)
        self._rtf_window: deque[tuple[float, float]] = deque()  # (wall time, sim time)
        self._status = SimStatus(params_version_applied=snap.version)
        self._publish_status()
        self._unsubscribe = store.subscribe(self._on_params)

    # --- lifecycle ------------------------------------------------------------------------------

    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="artro-sim", daemon=True)
        self._thread.start()

    def stop(self, timeout_s: float = 5.0) -> None:
        self._stop.set()
        self._wake.set()
        self._unsubscribe()
        if self._thread is not None:
            self._thread.join(timeout_s)
        if self._firmware is not None and not self.alive:
            self._firmware.close()
            self._firmware = None

    @property
    def alive(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    # --- commands (any thread) ------------------------------------------------------------------

    def command(self, command: Command | str, value: Any = None) -> None:
        """Queue a command for the next frame boundary; a bad one raises ValueError at once."""
        try:
            command = Command(command)
        except ValueError:
            allowed = ", ".join(c.value for c in Command)
            raise ValueError(f"unknown command {command!r}; allowed: {allowed}") from None
        if command is Command.DRIVE and not isinstance(value, DriveRequest | FirmwareDriver | None):
            raise ValueError(
                "the drive command takes a DriveRequest, a booted FirmwareDriver or None"
            )
        if command is Command.GHOST and value is not None:
            params, source = value
            if not isinstance(params, GaitParams) or not isinstance(source, str):
                raise ValueError("the ghost command takes (GaitParams, source label) or None")
        if command is Command.WORLD and not isinstance(value, Variation):
            raise ValueError("the world command takes a Variation")
        if command is Command.SPEED:
            lo, hi = SPEED_RANGE
            if not isinstance(value, int | float) or not lo <= float(value) <= hi:
                raise ValueError(f"speed must be {lo} to {hi} (x real time), got {value!r}")
        self._commands.put((command, value))
        self._wake.set()

    def switch_drive(self, drive: Drive | str) -> None:
        """Make the pulses with the model or the emulated firmware from the next frame boundary.
        The firmware is built and booted here, in the caller's thread (seconds on a cold build
        cache): ValueError for an unknown drive or a set the firmware cannot run, BuildError or
        EmulatorError if the tool chain or emulator fail. Either way nothing changes then."""
        try:
            drive = Drive(drive)
        except ValueError:
            allowed = ", ".join(d.value for d in Drive)
            raise ValueError(f"unknown drive {drive!r}; allowed: {allowed}") from None
        driver = None
        if drive is Drive.FIRMWARE:
            driver = FirmwareDriver.boot(
                self.store.snapshot(), self.hardware, self._loop.robot.geometry
            )
        request = DriveRequest(driver)
        self.command(Command.DRIVE, request)
        # the set may change while the firmware boots: the simulation thread has the last word
        if self.alive and request.answered.wait(DRIVE_ANSWER_S) and request.refused:
            raise ValueError(request.refused)

    def _on_params(self, snapshot: Snapshot, changed: frozenset[str], source: str) -> None:
        self.recorder.keep_params(snapshot.version, snapshot.parameter_set().to_dict())
        self.recorder.event(
            "params", version=snapshot.version, source=source, changed=sorted(changed)
        )
        if self._pending is None:
            self._pending = (self._status.frame, time.monotonic())
        self._wake.set()

    # --- reading (any thread) -------------------------------------------------------------------

    def body_poses(self) -> BodyPoses | None:
        return self._poses

    def ghost_status(self) -> GhostStatus | None:
        """The A/B ghost's last published state, None without a ghost."""
        return self._ghost_status

    def servo_load(self) -> ServoLoadReport:
        """The servo load budget since the last reset or parameter change (published)."""
        return self._load_report

    def status(self) -> SimStatus:
        """The last status the simulation thread published (never reads MjData)."""
        return self._status

    # --- the thread -----------------------------------------------------------------------------

    def _run(self) -> None:
        wall_anchor = time.monotonic()
        frames_since_anchor = 0
        while not self._stop.is_set():
            try:
                reanchor = self._drain_commands()
                self._apply_params()
                if reanchor or self.paused or self._loop.fell:
                    wall_anchor, frames_since_anchor = time.monotonic(), 0
                if self.paused or self._loop.fell:
                    self._record_rtf()
                    self._wake.wait(0.1)
                    self._wake.clear()
                    continue
                now = time.monotonic()
                due = math.floor((now - wall_anchor) * self.speed / FRAME_S) - frames_since_anchor
                if due > MAX_CATCHUP_FRAMES:
                    self.frames_dropped += due - MAX_CATCHUP_FRAMES
                    self.last_behind_wall = now
                    frames_since_anchor += due - MAX_CATCHUP_FRAMES
                    due = MAX_CATCHUP_FRAMES
                for _ in range(max(due, 0)):
                    self._apply_params()  # also between catch-up frames: no change waits a batch
                    self._frame()
                    frames_since_anchor += 1
                    if self._loop.fell:
                        break
                self._record_rtf()
                next_due = wall_anchor + (frames_since_anchor + 1) * FRAME_S / self.speed
                self._wake.wait(max(0.0, next_due - time.monotonic()))
                self._wake.clear()
            except Exception:  # the server must outlive any frame: report, reset, go on
                self.errors.append(traceback.format_exc(limit=3))
                log.exception("simulation frame failed; resetting")
                self._reset()
                wall_anchor, frames_since_anchor = time.monotonic(), 0

    def _drain_commands(self) -> bool:
        """Apply queued commands; True if the pacing must restart from now."""
        restart = False
        while True:
            try:
                command, value = self._commands.get_nowait()
            except queue.Empty:
                return restart
            if command is Command.PAUSE:
                self.paused = True
            elif command is Command.RESUME:
                self.paused, restart = False, True
            elif command is Command.RESET:
                self._reset()
                restart = True
            elif command is Command.STEP:
                self.paused = True
                self._apply_params()
                if not self._loop.fell:
                    self._frame()
            elif command is Command.SPEED:
                self.speed, restart = float(value), True
            elif command is Command.REANCHOR:
                self.paths.reanchor(value)
            elif command is Command.DRIVE:
                restart = self._take_drive(value)
            elif command is Command.WORLD:
                self._loop.set_variation(value)  # the state carries over: it walks on there
                if self._ghost is not None:  # the A/B comparison stays in one world
                    self._ghost.loop.set_variation(value)
            elif command is Command.GHOST:
                self._ghost = None if value is None else Ghost(self._loop, *value)
                self._ghost_status = None if value is None else self._ghost.status()
                self._publish_poses()

    def _apply_params(self) -> None:
        snap = self.store.snapshot()
        if snap.version == self._applied.version:
            return
        old = self._applied
        firmware = self._firmware
        switched = snap.robot != self.robot.name
        if switched:
            self._switch_robot(self._robots(snap.robot), snap)
        elif firmware is not None and snap.gait.engine != FIRMWARE_ENGINE:
            self.errors.append(
                f"firmware drive ended: the firmware runs the {FIRMWARE_ENGINE} engine and "
                f"version {snap.version} names {snap.gait.engine!r}; the model drives now"
            )
            self._set_drive(None, reset=False)
        elif firmware is not None:
            firmware.send(snap)  # over the emulated UART; it reaches the frame the ACK names
        if switched:
            pass  # the new robot's loop was built with this set
        elif snap.gait == old.gait:
            self._loop.set_gait(motion=snap.motion)  # a ramp under way goes on
        elif (
            self._firmware is None
            and snap.gait.engine == self._loop.params.engine
            and (self._gait_ramp is not None or gait_fields_changed(old.gait, snap.gait) > 1)
        ):
            # a new set of constants (a preset, an import, an undo of one) reaches the servos
            # over GAIT_RAMP_S, from those in effect now; one constant (a slider) at once
            self._gait_ramp = GaitRamp(self._loop.params, snap.gait, round(GAIT_RAMP_S / FRAME_S))
            self._loop.set_gait(motion=snap.motion)
        else:  # the firmware takes a set whole; a new engine has its own start-up
            self._gait_ramp = None
            self._loop.set_gait(snap.gait, snap.motion)
        self._load.clear()  # the budget belongs to one gait
        self.paths.set_gait(snap.motion.ca, snap.gait.clock.freq_hz)
        if snap.motion != old.motion:
            self.paths.reanchor()
        self._applied = snap
        if self._pending is not None:
            waited = self._loop.frame_index - self._pending[0]
            if self._firmware is None:
                # the next frame (number frame_index) is the first built with the change
                self.param_latency_frames.append(waited + 1)
            else:
                self._firmware_waited = waited  # the rest comes with the firmware's ACK
            self._pending = None

    def _switch_robot(self, robot: RobotModel, snap: Snapshot) -> None:
        """Simulate `robot` from now, standing at the start in `snap`'s set, in the same world.
        The firmware drive (built for the other robot's legs) and the ghost (the other
        robot's) end, said so; the recording, paths and scope start over."""
        if self._firmware is not None:
            self.errors.append(
                f"firmware drive ended: the robot is now {robot.name!r} (the firmware was built "
                f"for {self.robot.name!r}); the model drives now"
            )
            self._set_drive(None, reset=False)
        if self._ghost is not None:
            self.errors.append(
                f"the ghost ({self._ghost.source}) was removed: it walked {self.robot.name!r}"
            )
            self._ghost, self._ghost_status = None, None
        self._gait_ramp = None
        self.hardware = robot.hardware()
        self._loop = FrameLoop(
            robot=robot,
            params=snap.gait,
            motion=snap.motion,
            hardware=self.hardware,
            variation=self._loop.variation,
        )
        self.robot, self.model = robot, self._loop.model
        self._load = ServoLoadMeter(self._loop.robot)
        self._load_report = self._load.report()
        self.scope.tdm = self.hardware.tdm
        self.recorder.restart(_model_name(self.model))
        self.recorder.event("robot", robot=robot.name)
        self._reset()

    def _frame(self) -> None:
        sim = self._loop
        ramp = self._gait_ramp
        if ramp is not None:
            sim.set_gait(ramp.next())
            if ramp.finished:
                self._gait_ramp = None
                self._load.clear()  # the budget of the new gait, not of the way to it
        record = self._step()
        if sim.blew_up:
            self.errors.append(f"physics blew up at t = {sim.time_s:.2f} s; robot reset")
            self._reset()
            return
        if self._ghost is not None:
            self._step_ghost(record)
        self.recorder.add(record, sim.data.qpos, self._applied.version)
        if sim.fell:
            self.recorder.event("fall", motion=dataclasses.asdict(record.motion))
        self.scope.publish(record, self._applied.version)
        self._load.add(self._loop.data, record.saturated_servos)
        if record.index % LOAD_PUBLISH_FRAMES == 0:
            self._load_report = self._load.report()
        if record.index % SAMPLE_EVERY_FRAMES == 0:
            self.paths.add(sim.time_s, sim.trunk_pose(), sim.feet_distance_m())
        self._publish_poses()

    def _step_ghost(self, record: FrameRecord) -> None:
        """The ghost's frame; if it fails, the ghost goes, said so, and the live robot walks on."""
        try:
            self._ghost.step(self._loop, self._applied.motion, record.phase)
            if record.index % GHOST_PUBLISH_FRAMES == 0:
                self._ghost_status = self._ghost.status()
        except Exception as error:  # the ghost is a comparison: it must not stop the robot
            log.exception("ghost frame failed; ghost removed")
            self.errors.append(f"the ghost ({self._ghost.source}) failed and was removed: {error}")
            self._ghost, self._ghost_status = None, None

    def _step(self) -> FrameRecord:
        """One frame, its pulses made by the model or read off the firmware's pins."""
        firmware = self._firmware
        if firmware is not None:
            try:
                pins, problems, latencies = firmware.next_pins()
            except EmulatorError as error:
                self.errors.append(f"firmware drive ended: {error}; the model drives now")
                self._set_drive(None, reset=False)
            else:
                self.errors.extend(problems)
                self.param_latency_frames.extend(n + self._firmware_waited for n in latencies)
                return self._loop.step_pins(pins)
        return self._loop.step_frame()

    def _take_drive(self, request: DriveRequest | FirmwareDriver | None) -> bool:
        """A drive switch asked for; the firmware is refused if the set in use, or the one
        coming, names another engine (it may have changed while the firmware booted). True if
        the drive changed."""
        if not isinstance(request, DriveRequest):
            request = DriveRequest(request)
        driver = request.driver
        engines = {self._applied.gait.engine, self.store.snapshot().gait.engine}
        if driver is not None and engines != {FIRMWARE_ENGINE}:
            driver.close()
            request.refused = (
                f"firmware drive not started: the firmware runs the {FIRMWARE_ENGINE} gait "
                f"engine; the set in use now names {(engines - {FIRMWARE_ENGINE}).pop()!r} (it "
                f"changed while the firmware booted): choose engine {FIRMWARE_ENGINE} first"
            )
            self.errors.append(request.refused)  # also when no one waits for the answer
        else:
            self._set_drive(driver)
        request.answered.set()
        return request.refused is None

    def _set_drive(self, driver: FirmwareDriver | None, *, reset: bool = True) -> None:
        """Hand the pulses to `driver` (None: the model). A firmware boots at its start phase,
        so the robot is put back to the start then; back to the model, it walks on."""
        self._finish_gait_ramp()
        if self._firmware is not None:
            self._firmware.close()
        self._firmware = driver
        self._firmware_waited = 0
        self.recorder.event(
            "drive", drive=(Drive.MODEL if driver is None else Drive.FIRMWARE).value
        )
        if driver is not None:
            if self._applied.version != driver.built_version:
                driver.send(self._applied)  # the set changed while it was built
            if reset:
                self._reset(phase=START_PHASE_RAD)

    def _reset(self, phase: float | None = None) -> None:
        """Stand the robot at the start. With the firmware driving, its MCU runs on (a robot put
        back on its feet): the robot stands in the pose of the firmware's next phase."""
        if phase is None and self._firmware is not None:
            phase = self._loop.phase
        self._finish_gait_ramp()  # the robot stands up in the constants in use
        self._loop.reset(START_PHASE_RAD if phase is None else phase)
        if self._ghost is not None:
            self._ghost.place_beside(self._loop)
            self._ghost_status = self._ghost.status()
        self.resets += 1
        self.recorder.event("reset")
        self._rtf_window.clear()  # the simulated time restarts: a ratio across it means nothing
        self._load.clear()
        self.paths.clear()
        self.scope.clear()
        self._publish_poses()

    def _finish_gait_ramp(self) -> None:
        if self._gait_ramp is not None:
            self._loop.set_gait(self._gait_ramp.target)
            self._gait_ramp = None

    def _publish_poses(self) -> None:
        """A copy of the body poses for the 3D view: made only when a view exists."""
        if self.publish_poses:
            self._pose_serial += 1
            data, ghost = self._loop.data, self._ghost
            self._poses = BodyPoses(
                self._pose_serial,
                data.xpos.copy(),
                data.xmat.copy(),
                None if ghost is None else ghost.loop.data.xpos.copy(),
                None if ghost is None else ghost.loop.data.xmat.copy(),
            )

    def _record_rtf(self) -> None:
        now = time.monotonic()
        window = self._rtf_window
        window.append((now, self._loop.time_s))
        while len(window) > 2 and now - window[0][0] > RTF_WINDOW_S:
            window.popleft()
        self._publish_status()

    def _publish_status(self) -> None:
        """Copy what others may read out of the live state (this thread only)."""
        sim, window = self._loop, self._rtf_window
        rtf = None
        if len(window) >= 2 and window[-1][0] > window[0][0]:
            rtf = (window[-1][1] - window[0][1]) / (window[-1][0] - window[0][0])
        x, y, yaw = sim.trunk_pose()
        self._status = SimStatus(
            sim_time_s=sim.time_s,
            frame=sim.frame_index,
            rtf=rtf,
            speed=self.speed,
            paused=self.paused,
            fell=sim.fell,
            behind=time.monotonic() - self.last_behind_wall < BEHIND_SHOWN_S,
            frames_dropped=self.frames_dropped,
            trunk=TrunkPose(x, y, float(sim.data.qpos[2]), yaw),
            params_version_applied=self._applied.version,
            param_latency_frames=_summary(self.param_latency_frames),
            resets=self.resets,
            errors=tuple(self.errors),
            drive=(Drive.MODEL if self._firmware is None else Drive.FIRMWARE).value,
            world=self._loop.variation.name,
            robot=self.robot.name,
            firmware=None if self._firmware is None else self._firmware.status(),
            gait_ramp=None if self._gait_ramp is None else self._gait_ramp.progress,
        )


def _model_name(model: Any) -> str:
    return bytes(model.names).split(b"\0", 1)[0].decode() or "robot"


def _summary(values: deque[int]) -> LatencySummary:
    ordered = sorted(values)
    if not ordered:
        return LatencySummary()
    return LatencySummary(len(ordered), ordered[len(ordered) // 2], ordered[-1])
