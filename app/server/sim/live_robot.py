"""The live robot of `artro serve`: the robot the simulation thread simulates (its `FrameLoop`,
model and servo hardware), the drive (which pulses move its servos: the Python hardware model or
the emulated firmware of `emulated_controller.py`) and a change of gait constants on its way;
switching robot or drive in the order docs/DESIGN.md §10 gives."""

from __future__ import annotations

import dataclasses
import enum
import time
from collections import deque
from collections.abc import Callable

import mujoco

from app.firmware.emulator import EmulatorError
from app.firmware.mega_pulses import BoardFrame, MegaTrace
from app.robots.model import RobotModel
from app.server.param_store import Snapshot
from app.server.recording.recorder import Recorder
from app.server.sim.bus_port import BusPort
from app.server.sim.emulated_controller import EmulatedController, FirmwareStatus
from app.server.sim.gait_ramp import GAIT_RAMP_S, GaitRamp, gait_fields_changed
from app.server.sim.sim_commands import DriveRefused, SwitchDrive
from app.sim.frame_loop import FrameLoop
from app.sim.frame_record import FrameRecord
from app.sim.planning import FRAME_S, START_PHASE_RAD
from hardware import HardwareSetup
from hardware.firmware.schema import FIRMWARE_ENGINE
from hardware.servo_bus import bus_frame

LATENCY_KEPT = 100  # changes whose latency the status summarises


def model_name(model: mujoco.MjModel) -> str:
    """The name the model's description gives it (MJCF `<mujoco model=...>`), else "robot"."""
    return bytes(model.names).split(b"\0", 1)[0].decode() or "robot"


class Drive(enum.Enum):
    """Which pulses move the simulated servos (`artro serve --drive`, the page's pulses switch)."""

    MODEL = "model"  # the Python hardware model makes them
    FIRMWARE = "firmware"  # the robot's firmware on its emulated board; the servos read its output


class LiveRobot:
    """The simulation thread's alone, but for `robot`, `hardware` and `model`: those are replaced
    whole on a switch of robots, never changed, so any thread may read them.

    Ordering: a new parameter version reaches the pulses at the next frame boundary (over the
    firmware's UART while it drives, where it takes effect at the frame the ACK names); a switch
    of robots or a set naming another engine ends the firmware drive first, said so; a booted
    firmware is refused if the set in use, or the one coming, names another engine."""

    def __init__(
        self,
        robot: RobotModel,
        hardware: HardwareSetup,
        snapshot: Snapshot,
        *,
        recorder: Recorder,
        report: Callable[[str], None],
    ) -> None:
        """Simulate `robot` with the servo hardware `hardware` in `snapshot`'s set, the model
        making the pulses; drive switches go into `recorder`, problems to `report`."""
        self.robot = robot
        self.hardware = hardware
        self.loop = FrameLoop(
            robot=robot, params=snapshot.gait, motion=snapshot.motion, hardware=hardware
        )
        self.model = self.loop.model  # immutable once loaded
        self._recorder = recorder
        self._report = report
        self._controller: EmulatedController | None = None  # the firmware drive, when on
        self._controller_waited_frames = 0  # frames the change in flight waited before it was sent
        self._gait_ramp: GaitRamp | None = None  # a change of gait constants on its way
        # per applied change: frames from entering the store to the frame whose pulses carry it
        self.latency_frames: deque[int] = deque(maxlen=LATENCY_KEPT)
        #: `artro serve --servo-bus`: its goals move the servos while goal writes arrive
        self.bus_port: BusPort | None = None
        self.bus_driving = False  # the last frame's set-points were the bus's goals
        #: `artro serve --board`: the board the firmware drive emulates (None: the robot's own)
        self.board: str | None = None
        #: the Mega board's view of the last frame (PCA9685 channels, I2C), else None
        self.board_frame: BoardFrame | None = None

    @property
    def drive(self) -> Drive:
        return Drive.MODEL if self._controller is None else Drive.FIRMWARE

    @property
    def model_name(self) -> str:
        return model_name(self.model)

    @property
    def firmware_board(self) -> str:
        """The board the firmware drive emulates: `--board`, else the robot's `board:`."""
        return self.board or self.robot.description.board

    def board_trace(self) -> MegaTrace | None:
        """The Mega board's last frames while it drives (any thread may read them), else None."""
        controller = self._controller
        return None if controller is None else controller.trace

    def firmware_status(self) -> FirmwareStatus | None:
        return None if self._controller is None else self._controller.status()

    def gait_ramp_progress(self) -> float | None:
        """How far a change of gait constants has come (0..1), None when none is on its way."""
        return None if self._gait_ramp is None else self._gait_ramp.progress

    # --- the drive -------------------------------------------------------------------------------

    def boot_firmware(self, snapshot: Snapshot) -> EmulatedController:
        """Build and boot the firmware for `snapshot`'s set on this robot's legs and servo
        hardware, in the caller's thread (seconds on a cold build cache). ValueError for a set
        the firmware cannot run, BuildError or EmulatorError if the tool chain or emulator fail."""
        robot, hardware = self.robot, self.hardware  # replaced by the simulation thread
        if snapshot.robot != robot.name or self.robot is not robot:
            raise DriveRefused(
                f"the robot is changing to {snapshot.robot!r} (the simulation still runs "
                f"{robot.name!r}): switch the drive again in a moment",
                "robot_changed",
            )
        positions = tuple(map(tuple, robot.fsr_positions_m.tolist()))
        board = self.board or robot.description.board
        return EmulatedController.boot(snapshot, hardware, robot.geometry, positions, board)

    def take_drive(self, command: SwitchDrive, applied: Snapshot, coming: Snapshot) -> bool:
        """Answer a drive switch. The firmware is refused (closed, and said so also when no one
        waits for the answer) if the set in use or the one coming names another engine: it may
        have changed while the firmware booted. True if the pulses changed hands; a firmware
        boots at its start phase, so the caller then stands the robot at the start."""
        controller = command.controller
        engines = {applied.gait.engine, coming.gait.engine}
        refusal, reason = None, ""
        robots = {applied.robot, coming.robot, self.robot.name}
        if controller is not None and robots != {controller.robot}:
            controller.close()
            reason = "robot_changed"
            refusal = (
                f"firmware drive not started: it was built for the robot {controller.robot!r}; "
                f"the robot is now {coming.robot!r} (it changed while the firmware booted)"
            )
            self._report(refusal)
        elif controller is not None and engines != {FIRMWARE_ENGINE}:
            controller.close()
            reason = "unsupported_engine"
            refusal = (
                f"firmware drive not started: the firmware runs the {FIRMWARE_ENGINE} gait "
                f"engine; the set in use now names {(engines - {FIRMWARE_ENGINE}).pop()!r} (it "
                f"changed while the firmware booted): choose engine {FIRMWARE_ENGINE} first"
            )
            self._report(refusal)
        else:
            try:
                self._hand_pulses_to(controller)
                if controller is not None and applied.version != controller.built_version:
                    controller.send(applied)  # the set changed while it was built
            except Exception as exc:  # the asker hears of it at once, not after its wait
                command.answer.give(f"the drive switch failed: {exc}", "drive_failed")
                raise
        command.answer.give(refusal, reason)
        return refusal is None

    def _hand_pulses_to(self, controller: EmulatedController | None) -> None:
        """The pulses come from `controller` (None: the model) from the next frame on."""
        self._finish_gait_ramp()
        if self._controller is not None:
            self._controller.close()
        self._controller = controller
        self._controller_waited_frames = 0
        self._recorder.event("drive", drive=self.drive.value)

    def _end_firmware_drive(self, why: str) -> None:
        """Back to the model, said so; the robot walks on from where it is."""
        self._report(f"firmware drive ended: {why}; the model drives now")
        self._hand_pulses_to(None)

    def close(self) -> None:
        """Stop the emulated controller, if any (once the simulation thread has ended)."""
        if self._controller is not None:
            self._controller.close()
            self._controller = None

    # --- parameter versions and robots -----------------------------------------------------------

    def follow(self, snapshot: Snapshot, old: Snapshot) -> None:
        """A new version for this robot. With the firmware driving, it travels over the UART (a
        set naming another engine ends the firmware drive first). A new set of constants (a
        preset, an import, an undo of one) reaches the servos over GAIT_RAMP_S from those in
        effect; one constant (a slider) at once; the firmware takes a set whole and a new engine
        has its own start-up. The motion goes through the gait's own ramp."""
        controller = self._controller
        if controller is not None and snapshot.gait.engine != FIRMWARE_ENGINE:
            self._end_firmware_drive(
                f"the firmware runs the {FIRMWARE_ENGINE} engine and version {snapshot.version} "
                f"names {snapshot.gait.engine!r}"
            )
        elif controller is not None:
            controller.send(snapshot)  # over the emulated UART; it reaches the frame the ACK names
        if snapshot.gait == old.gait:
            self.loop.set_gait(motion=snapshot.motion)  # a ramp under way goes on
        elif (
            self._controller is None
            and snapshot.gait.engine == self.loop.params.engine
            and (self._gait_ramp is not None or gait_fields_changed(old.gait, snapshot.gait) > 1)
        ):
            frames = round(GAIT_RAMP_S / FRAME_S)
            self._gait_ramp = GaitRamp(self.loop.params, snapshot.gait, frames)
            self.loop.set_gait(motion=snapshot.motion)
        else:
            self._gait_ramp = None
            self.loop.set_gait(snapshot.gait, snapshot.motion)

    def count_latency(self, entered_at_frame: int) -> None:
        """A change that entered the store when frame `entered_at_frame` was done has been
        applied: with the model, the next frame is the first built with it; with the firmware,
        the rest of its latency comes with the ACK."""
        waited = self.loop.frame_index - entered_at_frame
        if waited < 0:  # the frames were counted anew between (a reset, another robot's loop)
            return
        if self._controller is None:
            self.latency_frames.append(waited + 1)
        else:
            self._controller_waited_frames = waited

    def switch_robot(self, robot: RobotModel, snapshot: Snapshot) -> None:
        """Simulate `robot` from now, in `snapshot`'s set, in the same world. The firmware drive
        (built for the other robot's legs) ends first, said so; the caller stands the new robot
        at the start."""
        if self._controller is not None:
            self._end_firmware_drive(
                f"the robot is now {robot.name!r} (the firmware was built for {self.robot.name!r})"
            )
        self._gait_ramp = None
        hardware = robot.hardware()
        self.hardware = hardware
        self.loop = FrameLoop(
            robot=robot,
            params=snapshot.gait,
            motion=snapshot.motion,
            hardware=hardware,
            variation=self.loop.variation,
        )
        self.robot, self.model = robot, self.loop.model

    # --- frames ----------------------------------------------------------------------------------

    def step(self) -> tuple[FrameRecord, bool]:
        """One frame: the ramp's next constants, then the set-points: a servo bus's goals while
        its goal writes arrive (`BusPort`), else the pulses made by the model or read off the
        firmware's pins (an emulator that fails ends the firmware drive, said so, and the model
        makes this frame's). Also True if a change of gait constants arrived with it."""
        self.board_frame = None
        port = self.bus_port
        if port is None:
            return self._step_pulses()
        goals = port.take(time.monotonic())
        self.bus_driving = goals is not None
        if goals is not None:  # as the frame's sync write of them: acting once it is through
            sent = bus_frame(self.loop.frame_index, goals, **dataclasses.asdict(port.link))
            result = self.loop.step_goals(goals, sent.substep()), False
        else:
            result = self._step_pulses()
        port.publish(self.robot, self.loop.data)
        return result

    def _step_pulses(self) -> tuple[FrameRecord, bool]:
        arrived = False
        ramp = self._gait_ramp
        if ramp is not None:
            self.loop.set_gait(ramp.next())
            if ramp.finished:
                self._gait_ramp, arrived = None, True
        controller = self._controller
        if controller is not None:
            try:
                pins, problems, latencies = controller.next_pins()
            except EmulatorError as error:
                self._end_firmware_drive(str(error))
            else:
                for problem in problems:
                    self._report(problem)
                waited = self._controller_waited_frames
                self.latency_frames.extend(n + waited for n in latencies)
                self.board_frame = controller.board_frame
                record = self.loop.step_pins(pins)
                if record.reading is not None:  # the firmware reads it in the next frame
                    controller.sense(record.reading)
                return record, arrived
        return self.loop.step_frame(), arrived

    def reset(self, phase_rad: float | None = None) -> None:
        """Stand the robot at `phase_rad` (default: the start) in the constants in use. With the
        firmware driving, its MCU runs on (a robot put back on its feet): by default the robot
        stands in the pose of the firmware's next phase."""
        if phase_rad is None and self._controller is not None:
            phase_rad = self.loop.phase
        self._finish_gait_ramp()
        self.loop.reset(START_PHASE_RAD if phase_rad is None else phase_rad)

    def _finish_gait_ramp(self) -> None:
        if self._gait_ramp is not None:
            self.loop.set_gait(self._gait_ramp.target)
            self._gait_ramp = None
