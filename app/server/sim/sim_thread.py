"""The simulation thread of `artro serve`. It alone owns the live robot's `FrameLoop` and MjData
(docs/DESIGN.md §10) and composes the parts: pacing (`pacing.py`), typed commands
(`sim_commands.py`), the live robot and its drive (`live_robot.py`), the ghost, recorder, scope
feed and paths, and what it publishes (`published.py`). Others send commands, change the
parameter store, and read what it publishes."""

from __future__ import annotations

import dataclasses
import logging
import math
import threading
import time
import traceback
from collections import deque
from collections.abc import Callable

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
from app.server.sim.path_tracker import SAMPLE_EVERY_FRAMES, PathTracker
from app.server.sim.published import (
    GHOST_PUBLISH_FRAMES,
    SENSORS_PUBLISH_FRAMES,
    SENSORS_WATCHED_S,
    BodyPoses,
    Bulletin,
    LatencySummary,
    PushMark,
    SimStatus,
    TrunkPose,
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
from app.sim.frame_loop import FrameRecord
from app.sim.planning import FRAME_S, START_PHASE_RAD
from app.sim.servo_load import ServoLoadReport
from app.worlds.variations import NOMINAL, Variation
from hardware import HardwareSetup

log = logging.getLogger(__name__)

IDLE_WAIT_S = 0.1  # paused or fallen, the thread looks at its commands this often at least
DRIVE_ANSWER_S = 10.0  # how long a drive switch waits for the simulation thread's verdict
ERRORS_KEPT = 20
#: a blow-up this soon after the robot was stood up again is "at once"; twice at once in a row
#: pauses the robot (a world or set that cannot be simulated would blow up every frame)
QUICK_BLOW_UP_FRAMES = 50
BLOW_UPS_BEFORE_PAUSE = 2


class SimThread:
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

    def _recover(self) -> None:
        """Stand the robot again after a failed frame; if even that fails, in the nominal world;
        if that fails too, pause, said so. The thread itself never ends here."""
        try:
            self._reset()
            return
        except Exception as error:
            log.exception("the reset after a failure failed too")
            failed = error
        world = self.live.loop.variation
        if not world.is_nominal:
            try:
                self._set_world(NOMINAL)
                self._reset()
                self.errors.append(
                    f"the world {world.name} could not be simulated ({failed!r}); the robot "
                    "walks on in the nominal world"
                )
                return
            except Exception as error:
                log.exception("the reset in the nominal world failed too")
                failed = error
        self.paused = True
        self.errors.append(
            f"the robot cannot be stood up again ({failed!r}); paused: change the parameters, "
            "the world or the robot, then reset"
        )

    def _set_world(self, variation: Variation) -> None:
        self.live.loop.set_variation(variation)  # the state carries over
        if self._ghost is not None:  # the A/B comparison stays in one world
            self._ghost.loop.set_variation(variation)

    def _change_world(self, variation: Variation) -> None:
        """Walk on in `variation`; one that cannot be simulated is dropped, said so, and the
        robot walks on in the world it was in."""
        before = self.live.loop.variation
        try:
            self._set_world(variation)
        except Exception as error:
            log.exception("world %s refused", variation.name)
            self._set_world(before)
            self.errors.append(
                f"the world {variation.name} could not be simulated ({error!r}); the robot "
                f"stays in {before.name}"
            )
        self._quick_blow_ups = 0

    def _take_commands(self) -> bool:
        """Carry out the queued commands; True if the pacing must restart from now."""
        restart = False
        for command in self._commands.drain():
            if isinstance(command, Pause):
                if isinstance(command, PauseForReplay):
                    command.was_paused.put(self.paused)
                self.paused = True
            elif isinstance(command, Resume):
                self.paused, restart = False, True
            elif isinstance(command, Reset):
                self._reset()
                restart = True
            elif isinstance(command, Step):
                self.paused = True
                self._apply_params()
                if not self.live.loop.fell:
                    self._frame()
            elif isinstance(command, SetSpeed):
                self.pacer.set_speed(command.speed)
            elif isinstance(command, Reanchor):
                self.paths.reanchor(command.speed_m_s)
            elif isinstance(command, SwitchDrive):
                if self.live.take_drive(command, self._applied, self.store.snapshot()):
                    restart = True
                    if command.controller is not None:  # a firmware boots at its start phase
                        self._reset(START_PHASE_RAD)
            elif isinstance(command, SetWorld):
                self._change_world(command.variation)
            elif isinstance(command, SetGhost):
                self._ghost = Ghost(self.live.loop, command.params, command.source)
                self.bulletin.ghost = self._ghost.status()
                self._publish_poses()
            elif isinstance(command, RemoveGhost):
                self._ghost, self.bulletin.ghost = None, None
                self._publish_poses()
            elif isinstance(command, Push):
                self._push(command)
        return restart

    def _push(self, push: Push) -> None:
        loop = self.live.loop
        if loop.fell:  # it fell after the request was answered: nothing steps to push
            self.pending_pushes.settle(push.impulse_n_s)
            return
        self._taken_push_n_s += push.impulse_n_s  # acts in the next physics step
        summed = loop.push_now(push.impulse_n_s, push.direction_deg)  # with one due, added
        x, y, yaw = loop.trunk_pose()
        world_deg = (math.degrees(yaw) + push.direction_deg + 180.0) % 360.0 - 180.0
        z = float(loop.data.qpos[2])
        impulse, acting_deg = push.impulse_n_s, world_deg
        if summed is not None:  # the mark shows what acts: the two pushes' sum
            impulse = math.hypot(*summed)
            acting_deg = math.degrees(math.atan2(summed[1], summed[0]))
        toward_deg = (acting_deg - math.degrees(yaw)) % 360.0  # as given: -180 < it <= 180
        toward_deg = toward_deg - 360.0 if toward_deg > 180.0 else toward_deg
        self._last_push = PushMark(loop.time_s, impulse, acting_deg, x, y, z, toward_deg)
        self.recorder.event("push", impulse_n_s=push.impulse_n_s, direction_deg=world_deg)
        self._publish_status()

    def _apply_params(self) -> None:
        snap = self.store.snapshot()
        if snap.version in (self._applied.version, self._refused_version):
            return
        old = self._applied
        try:
            if snap.robot != self.live.robot.name:
                self._switch_robot(self._robots(snap.robot), snap)  # built in this set
            else:
                self.live.follow(snap, old)
        except Exception as error:  # the robot walks on in the set it has, said so
            log.exception("parameter set v%d could not be applied", snap.version)
            self._refused_version = snap.version
            self.errors.append(
                f"parameter set v{snap.version} could not be applied ({error!r}); the robot "
                f"walks on in v{old.version}"
            )
            return
        self._quick_blow_ups = 0
        self.bulletin.clear_load()  # the budget belongs to one gait
        self.paths.set_gait(snap.motion.ca, snap.gait.clock.freq_hz)
        if snap.motion != old.motion:
            self.paths.reanchor()
        self._applied = snap
        with self._pending_lock:  # a version committed after `snap` waits for its own frame
            applied = [v for v in self._pending_frames if v <= snap.version]
            since = [self._pending_frames.pop(v) for v in applied]
        if since:
            self.live.count_latency(min(since))

    def _switch_robot(self, robot: RobotModel, snap: Snapshot) -> None:
        """Simulate `robot` from now, standing at the start in `snap`'s set, in the same world.
        The firmware drive (built for the other robot's legs) and the ghost (the other robot's)
        end, said so; the recording, paths, scope and the errors start over (what they said was
        of the other robot: an undo back must not keep "the robot is now ...")."""
        before = self.live.robot.name
        self.errors.clear()
        self.live.switch_robot(robot, snap)
        if self._ghost is not None:
            self.errors.append(
                f"the ghost ({self._ghost.source}) was removed: it walked {before!r}"
            )
            self._ghost, self.bulletin.ghost = None, None
        self.bulletin.measure_load_of(self.live.loop.robot)
        self.sensors.measure(self.live.loop.robot)
        self.scope.tdm = self.live.hardware.tdm
        self.scope.bus = self.live.hardware.bus
        self.recorder.restart(self.live.model_name)
        self.recorder.event("robot", robot=robot.name)
        self._reset()

    def _frame(self) -> None:
        live = self.live
        self._watch_sensors_if_asked()
        record, gait_arrived = live.step()
        self._pushes_acted()
        if gait_arrived:
            self.bulletin.clear_load()  # the budget of the new gait, not of the way to it
        loop = live.loop
        if loop.blew_up:
            self._blown_up(loop.time_s, loop.frame_index)
            return
        if self._ghost is not None:
            self._step_ghost(record)
        self.recorder.add(record, loop.data.qpos, self._applied.version)
        if loop.fell:
            self.recorder.event("fall", motion=dataclasses.asdict(record.motion))
        self.scope.publish(record, self._applied.version)
        self.bulletin.add_load(loop.data, record.saturated_servos, record.index)
        self.sensors.add(record, loop.data)
        if record.index % SENSORS_PUBLISH_FRAMES == 0:
            self.bulletin.sensors = self.sensors.view()
        if record.index % SAMPLE_EVERY_FRAMES == 0:
            self.paths.add(loop.time_s, loop.trunk_pose(), loop.feet_distance_m())
        self._publish_poses()

    def _pushes_acted(self) -> None:
        """The pushes taken into the loop acted (a frame stepped) or were dropped (a reset):
        they wait no longer."""
        self.pending_pushes.settle(self._taken_push_n_s)
        self._taken_push_n_s = 0.0

    def _blown_up(self, time_s: float, frames: int) -> None:
        """Reset after a blow-up; the second in a row within a second of a start pauses the
        robot, said once, naming the world (it would blow up every frame)."""
        quick = frames <= QUICK_BLOW_UP_FRAMES
        self._quick_blow_ups = self._quick_blow_ups + 1 if quick else 0
        self._reset()
        if self._quick_blow_ups < BLOW_UPS_BEFORE_PAUSE:
            self.errors.append(f"physics blew up at t = {time_s:.2f} s; robot reset")
            return
        self._quick_blow_ups = 0
        self.paused = True
        self.errors.append(
            f"physics blows up within {QUICK_BLOW_UP_FRAMES * FRAME_S:g} s of every start in the "
            f"world {self.live.loop.variation.name} with parameter set v{self._applied.version}; "
            "paused: change the world, the parameters or the robot, then resume"
        )

    def _watch_sensors_if_asked(self) -> None:
        """The live loop reads its sensors while someone asked for them lately; watching anew,
        the trace starts over (no gap inside it)."""
        loop = self.live.loop
        asked = time.monotonic() - self.bulletin.sensors_asked_at < SENSORS_WATCHED_S
        if asked and not loop.watch_sensors:
            self.sensors.clear()
        # the firmware drive reads them always: its emulated IMU and ADC carry them to it
        loop.watch_sensors = asked or self.live.drive is Drive.FIRMWARE

    def _step_ghost(self, record: FrameRecord) -> None:
        """The ghost's frame; if it fails, the ghost goes, said so, and the live robot walks on."""
        ghost = self._ghost
        assert ghost is not None
        try:
            ghost.step(self.live.loop, self._applied.motion, record.phase)
            if record.index % GHOST_PUBLISH_FRAMES == 0:
                self.bulletin.ghost = ghost.status()
        except Exception as error:  # the ghost is a comparison: it must not stop the robot
            log.exception("ghost frame failed; ghost removed")
            self.errors.append(f"the ghost ({ghost.source}) failed and was removed: {error}")
            self._ghost, self.bulletin.ghost = None, None

    def _reset(self, phase_rad: float | None = None) -> None:
        """Stand the robot at the start (or at `phase_rad`; with the firmware driving, at the
        firmware's next phase) and start over what measures the walk."""
        self.live.reset(phase_rad)
        if self._ghost is not None:
            self._ghost.place_beside(self.live.loop)
            self.bulletin.ghost = self._ghost.status()
        self.resets += 1
        self.recorder.event("reset")
        self.pacer.clear_rtf()  # the simulated time restarts: a ratio across it means nothing
        self.bulletin.clear_load()
        self.paths.clear()
        self.scope.clear()
        self.sensors.clear()
        self._last_push = None
        self._pushes_acted()  # the loop stood up again has none due
        self._publish_poses()

    # --- publishing (this thread only) -----------------------------------------------------------

    def _publish_poses(self) -> None:
        ghost = self._ghost
        self.bulletin.publish_body_poses(
            self.live.model, self.live.loop.data, None if ghost is None else ghost.loop.data
        )

    def _sample_and_publish(self) -> None:
        self.pacer.sample(self.live.loop.time_s)
        self._publish_status()

    def _publish_status(self) -> None:
        """Copy what others may read out of the live state."""
        live, loop, pacer = self.live, self.live.loop, self.pacer
        x, y, yaw = loop.trunk_pose()
        self.bulletin.status = SimStatus(
            sim_time_s=loop.time_s,
            frame=loop.frame_index,
            rtf=pacer.rtf(),
            speed=pacer.speed,
            paused=self.paused,
            fell=loop.fell,
            behind=pacer.behind(),
            frames_dropped=pacer.frames_dropped,
            trunk=TrunkPose(x, y, float(loop.data.qpos[2]), yaw),
            params_version_applied=self._applied.version,
            param_latency_frames=LatencySummary.of(live.latency_frames),
            resets=self.resets,
            errors=tuple(self.errors),
            drive=live.drive.value,
            firmware=live.firmware_status(),
            gait_ramp=live.gait_ramp_progress(),
            world=loop.variation.name,
            robot=live.robot.name,
            push=self._last_push,
        )
