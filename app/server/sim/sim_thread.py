"""The simulation thread of `artro serve`: alone owns the live robot's `FrameLoop` and MjData
(docs/DESIGN.md §10); composes pacing (`pacing.py`), typed commands (`sim_commands.py`, each
carried out by its handler in `COMMAND_HANDLERS`), the live robot (`live_robot.py`), its own
work (`sim_work.py`) and what it publishes (`published.py`). Others send commands, change the
store, and read what it publishes."""

from __future__ import annotations

import logging
import threading
import time
import traceback
from collections import deque
from collections.abc import Callable
from typing import Any

import mujoco

from app.robots.model import RobotModel
from app.server.feeds.scope_feed import ScopeFeed
from app.server.param_store import ParameterStore, Snapshot
from app.server.recording.recorder import Recorder
from app.server.recording.sensor_trace import SensorTrace, SensorView
from app.server.robot_shelf import RobotShelf
from app.server.sim.ghost import Ghost, GhostStatus
from app.server.sim.live_robot import Drive, LiveRobot, model_name
from app.server.sim.pacing import Pacer
from app.server.sim.path_tracker import PathTracker
from app.server.sim.published import (
    BodyPoses,
    Bulletin,
    PushMark,
    SimStatus,
)
from app.server.sim.sim_commands import (
    CommandQueue,
    DriveRefused,
    Pause,
    PauseForReplay,
    PendingPushes,
    Push,
    Reanchor,
    RemoveGhost,
    Reset,
    Resume,
    SetGhost,
    SetSpeed,
    SetWorld,
    SimCommand,
    Step,
    SwitchDrive,
)
from app.server.sim.sim_work import SimWork
from app.sim.planning import START_PHASE_RAD
from app.sim.servo_load import ServoLoadReport
from hardware import HardwareSetup

log = logging.getLogger(__name__)

IDLE_WAIT_S = 0.1  # paused or fallen, the thread looks at its commands this often at least
DRIVE_ANSWER_S = 10.0  # how long a drive switch waits for the simulation thread's verdict
ERRORS_KEPT = 20


class SimThread(SimWork):
    """The thread that runs the live robot frame by frame, paced to the wall clock. Any thread
    may send it commands and read what it publishes; nothing else touches its MjData."""

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
        self._robots = robots or RobotShelf(robot).get
        snap = store.snapshot()
        self.errors: deque[str] = deque(maxlen=ERRORS_KEPT)
        # this thread writes the recorder; others take copies
        self.recorder = Recorder(robot.model.nq, model_name(robot.model))
        self.live = LiveRobot(  # this thread's alone (its robot, model, hardware: any thread's)
            robot,
            hardware or robot.hardware(),
            snap,
            recorder=self.recorder,
            report=self.errors.append,
        )
        self.recorder.keep_params(snap.version, snap.parameter_set().to_dict())
        self.scope = ScopeFeed(self.live.hardware.tdm, self.live.hardware.bus)
        self.paths = PathTracker()
        self.sensors = SensorTrace(robot)  # this thread writes; others read bulletin.sensors
        self._last_push: PushMark | None = None
        self.pending_pushes = PendingPushes()  # any thread admits; this thread settles
        self._taken_push_n_s = 0.0  # pushes taken into the loop that have not stepped yet
        self.paths.set_gait(snap.motion.ca, snap.gait.clock.freq_hz)
        self.pacer = Pacer()
        self._ghost: Ghost | None = None  # the A/B ghost, this thread's alone
        self._wake = threading.Event()
        self._commands = CommandQueue(self._wake)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._applied = snap
        #: the frame each version not yet applied was committed in (committing threads add,
        #: the simulation thread takes those it applied), under its own lock
        self._pending_frames: dict[int, int] = {}
        self._pending_lock = threading.Lock()
        self.paused = False
        self.resets = 0
        self._quick_blow_ups = 0  # blow-ups in a row, each within QUICK_BLOW_UP_FRAMES of a start
        self._refused_version: int | None = None  # a set that could not be applied: not retried
        status = SimStatus(params_version_applied=snap.version)
        self.bulletin = Bulletin(status, self.live.loop.robot)
        self._publish_status()
        self._unsubscribe = store.subscribe(self._on_params)

    # --- what any thread may read ---------------------------------------------------------------

    @property
    def robot(self) -> RobotModel:
        """The robot simulated: replaced whole on a switch of robots, never changed."""
        return self.live.robot

    @property
    def model(self) -> mujoco.MjModel:
        """The robot's compiled MjModel (immutable once loaded)."""
        return self.live.model

    @property
    def hardware(self) -> HardwareSetup:
        return self.live.hardware

    @property
    def publish_poses(self) -> bool:
        return self.bulletin.publish_poses

    @publish_poses.setter
    def publish_poses(self, on: bool) -> None:
        """Set by the 3D view, the only reader of body poses: copies are made only for it."""
        self.bulletin.publish_poses = on

    def status(self) -> SimStatus:
        """The last status the simulation thread published (never reads MjData)."""
        return self.bulletin.status

    def body_poses(self) -> BodyPoses | None:
        return self.bulletin.poses

    def ghost_status(self) -> GhostStatus | None:
        """The A/B ghost's last published state, None without a ghost."""
        return self.bulletin.ghost

    def servo_load(self) -> ServoLoadReport:
        """The servo load budget since the last reset or parameter change (published)."""
        return self.bulletin.servo_load

    def sensor_view(self) -> SensorView | None:
        """The sensors' and the laws' last frames (published), None before the first. Asking
        keeps the live loop reading its sensors for SENSORS_WATCHED_S more: nobody asking, the
        frame loop spares their cost."""
        self.bulletin.sensors_asked_at = time.monotonic()
        return self.bulletin.sensors

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
        if not self.alive:
            self.live.close()

    @property
    def alive(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    # --- commands (any thread) ------------------------------------------------------------------

    def send(self, command: SimCommand) -> None:
        """Queue a command for the next frame boundary; ValueError for anything else."""
        self._commands.put(command)

    def push(self, push: Push) -> None:
        """Queue `push`; PushRefused, nothing queued, where those already waiting for the next
        physics step would add up past PUSH_PENDING_MAX_N_S (they all act in that step)."""
        self.pending_pushes.admit(push)
        self.send(push)

    def switch_drive(self, drive: Drive | str) -> None:
        """Make the pulses with the model or the emulated firmware from the next frame boundary.
        The firmware is built and booted here, in the caller's thread (seconds on a cold build
        cache): ValueError for an unknown drive or a set the firmware cannot run, BuildError or
        EmulatorError if the tool chain or emulator fail. Either way nothing changes then.
        TimeoutError if the simulation thread did not answer within DRIVE_ANSWER_S."""
        try:
            drive = Drive(drive)
        except ValueError:
            allowed = ", ".join(d.value for d in Drive)
            raise ValueError(f"unknown drive {drive!r}; allowed: {allowed}") from None
        controller = None
        if drive is Drive.FIRMWARE:
            controller = self.live.boot_firmware(self.store.snapshot())
        command = SwitchDrive(controller)
        self.send(command)
        # the set may change while the firmware boots: the simulation thread has the last word
        if not self.alive:
            return
        if not command.answer.wait(DRIVE_ANSWER_S):
            raise TimeoutError(
                f"the simulation did not take the drive within {DRIVE_ANSWER_S:g} s: GET "
                "/api/state says which drive is on"
            )
        if command.answer.refusal:
            raise DriveRefused(command.answer.refusal, command.answer.reason)

    def _on_params(self, snapshot: Snapshot, changed: frozenset[str], source: str) -> None:
        self.recorder.keep_params(snapshot.version, snapshot.parameter_set().to_dict())
        self.recorder.event(
            "params", version=snapshot.version, source=source, changed=sorted(changed)
        )
        with self._pending_lock:
            self._pending_frames[snapshot.version] = self.bulletin.status.frame
        self._wake.set()

    # --- the thread -----------------------------------------------------------------------------

    def _run(self) -> None:
        pacer = self.pacer
        pacer.restart()
        while not self._stop.is_set():
            try:
                restart = self._take_commands()
                self._apply_params()
                if restart or self.paused or self.live.loop.fell:
                    pacer.restart()
                if self.paused or self.live.loop.fell:
                    self._sample_and_publish()
                    self._wake.wait(IDLE_WAIT_S)
                    self._wake.clear()
                    continue
                for _ in range(pacer.frames_due()):
                    self._apply_params()  # also between catch-up frames: no change waits a batch
                    self._frame()
                    pacer.frame_done()
                    if self.live.loop.fell:
                        break
                self._sample_and_publish()
                self._wake.wait(pacer.wait_s())
                self._wake.clear()
            except Exception:  # the server must outlive any frame: report, reset, go on
                self.errors.append(traceback.format_exc(limit=3))
                log.exception("simulation frame failed; resetting")
                self._recover()
                pacer.restart()

    def _take_commands(self) -> bool:
        """Carry out the queued commands, each by its handler (`COMMAND_HANDLERS`, keyed by the
        command's type); True if the pacing must restart from now."""
        restart = False
        for command in self._commands.drain():
            restart = handler_of(command)(self, command) or restart
        return restart

    # --- the commands' handlers (this thread only): True if the pacing restarts from now ------

    def _on_pause(self, command: Pause) -> bool:
        self.paused = True
        return False

    def _on_pause_for_replay(self, command: PauseForReplay) -> bool:
        command.was_paused.put(self.paused)
        self.paused = True
        return False

    def _on_resume(self, command: Resume) -> bool:
        self.paused = False
        return True

    def _on_reset(self, command: Reset) -> bool:
        self._reset()
        return True

    def _on_step(self, command: Step) -> bool:
        self.paused = True
        self._apply_params()
        if not self.live.loop.fell:
            self._frame()
        return False

    def _on_set_speed(self, command: SetSpeed) -> bool:
        self.pacer.set_speed(command.speed)
        return False

    def _on_reanchor(self, command: Reanchor) -> bool:
        self.paths.reanchor(command.speed_m_s)
        return False

    def _on_switch_drive(self, command: SwitchDrive) -> bool:
        if not self.live.take_drive(command, self._applied, self.store.snapshot()):
            return False
        if command.controller is not None:  # a firmware boots at its start phase
            self._reset(START_PHASE_RAD)
        return True

    def _on_set_world(self, command: SetWorld) -> bool:
        self._change_world(command.variation)
        return False

    def _on_set_ghost(self, command: SetGhost) -> bool:
        self._ghost = Ghost(self.live.loop, command.params, command.source)
        self.bulletin.ghost = self._ghost.status()
        self._publish_poses()
        return False

    def _on_remove_ghost(self, command: RemoveGhost) -> bool:
        self._ghost, self.bulletin.ghost = None, None
        self._publish_poses()
        return False

    def _on_push(self, command: Push) -> bool:
        self._push(command)
        return False


#: how the simulation thread carries out each type of command (a new command: its handler here)
COMMAND_HANDLERS: dict[type, Callable[[SimThread, Any], bool]] = {
    Pause: SimThread._on_pause,
    PauseForReplay: SimThread._on_pause_for_replay,
    Resume: SimThread._on_resume,
    Reset: SimThread._on_reset,
    Step: SimThread._on_step,
    SetSpeed: SimThread._on_set_speed,
    Reanchor: SimThread._on_reanchor,
    SwitchDrive: SimThread._on_switch_drive,
    SetWorld: SimThread._on_set_world,
    SetGhost: SimThread._on_set_ghost,
    RemoveGhost: SimThread._on_remove_ghost,
    Push: SimThread._on_push,
}


def handler_of(command: SimCommand) -> Callable[[SimThread, Any], bool]:
    """The handler of `command`'s type, or of the nearest type it derives from."""
    for kind in type(command).__mro__:
        if kind in COMMAND_HANDLERS:
            return COMMAND_HANDLERS[kind]
    raise ValueError(f"not a command of the simulation thread: {command!r}")
