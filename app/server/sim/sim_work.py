"""What the simulation thread does on its own state between its commands (docs/DESIGN.md §10):
a frame, a reset, a recovery after a failed frame, a world changed, a push taken, a parameter
version applied, a switch of robots, and what it publishes. `SimThread` (`sim_thread.py`) is
this with its lifecycle, its readers and its commands; only its thread calls these."""

from __future__ import annotations

import dataclasses
import logging
import math
import threading
import time
from collections import deque
from collections.abc import Callable

from app.robots.model import RobotModel
from app.server.feeds.scope_feed import ScopeFeed
from app.server.param_store import ParameterStore, Snapshot
from app.server.recording.recorder import Recorder
from app.server.recording.sensor_trace import SensorTrace
from app.server.sim.ghost import Ghost
from app.server.sim.live_robot import Drive, LiveRobot
from app.server.sim.pacing import Pacer
from app.server.sim.path_tracker import SAMPLE_EVERY_FRAMES, PathTracker
from app.server.sim.published import (
    GHOST_PUBLISH_FRAMES,
    SENSORS_PUBLISH_FRAMES,
    SENSORS_WATCHED_S,
    Bulletin,
    LatencySummary,
    PushMark,
    SimStatus,
    TrunkPose,
)
from app.server.sim.sim_commands import PendingPushes, Push
from app.sim.frame_record import FrameRecord
from app.sim.planning import FRAME_S
from app.worlds.variations import NOMINAL, Variation

log = logging.getLogger(__name__)

#: a blow-up this soon after the robot was stood up again is "at once"; twice at once in a row
#: pauses the robot (a world or set that cannot be simulated would blow up every frame)
QUICK_BLOW_UP_FRAMES = 50
BLOW_UPS_BEFORE_PAUSE = 2


class SimWork:
    """The simulation thread's own work on the live robot (its attributes are set by
    `SimThread.__init__`)."""

    store: ParameterStore
    live: LiveRobot
    errors: deque[str]
    recorder: Recorder
    scope: ScopeFeed
    paths: PathTracker
    sensors: SensorTrace
    pending_pushes: PendingPushes
    pacer: Pacer
    bulletin: Bulletin
    paused: bool
    resets: int
    _robots: Callable[[str], RobotModel]
    _ghost: Ghost | None
    _last_push: PushMark | None
    _taken_push_n_s: float
    _applied: Snapshot
    _pending_frames: dict[int, int]
    _pending_lock: threading.Lock
    _quick_blow_ups: int
    _refused_version: int | None

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
        self.recorder.add(record, loop.data.qpos, self._applied.version, live.board_frame)
        if loop.fell:
            self.recorder.event("fall", motion=dataclasses.asdict(record.motion))
        port = live.bus_port  # while a servo bus drives, the scope shows its goals' sync write
        self.scope.bus = port.link if port and live.bus_driving else live.hardware.bus
        self.scope.publish(record, self._applied.version, live.board_frame)
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
