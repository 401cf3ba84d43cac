"""The emulated controller of the firmware drive (docs/DESIGN.md §5, §10): the robot's board running
its firmware (simavr): ArtRo's ATmega128, whose pins the simulated servos read, or the Mega with its
PCA9685 (docs/BOARDS.md), and the parameter sets that travel to it over its emulated UART. Booted in
the caller's thread, then the simulation thread's."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Any

from app.firmware import protocol as proto
from app.firmware.build import DEFAULT_BOARD, check_board
from app.firmware.closed_loop import read_law_output
from app.firmware.mega_pulses import BoardFrame, MegaPulses, MegaTrace
from app.firmware.pulses import FirmwarePulses
from app.server.param_store import Snapshot
from app.sim.frame_record import PinFrame
from app.sim.planning import FRAME_S
from app.sim.sensors import SensorReading
from gait import ARTRO_LEG, LegGeometry, ramp_motion
from gait.feedback import laws_on
from hardware import HardwareSetup
from hardware.firmware.schema import FIRMWARE_ENGINE

BUSY_BUDGET_CYCLES = 128_000  # 80 % of the 160 000-cycle planning window (docs/DESIGN.md §5)
BUSY_WINDOW_FRAMES = 50


@dataclass(frozen=True)
class FirmwareStatus:
    """What the firmware drive publishes with the simulation's status."""

    mcu_frame: int = 0  # the firmware's own frame counter
    busy_cycles_last: int = 0
    busy_cycles_max: int = 0  # over the last second
    busy_budget_cycles: int = BUSY_BUDGET_CYCLES
    params_version_acked: int = 0  # the last parameter version the firmware acknowledged
    sets_in_flight: int = 0  # sent, not yet answered (one at most)
    sets_skipped: int = 0  # versions replaced by a newer one before they went (never sent)
    naks: int = 0
    laws_on: tuple[str, ...] = ()  # the feedback laws the set in force switches on
    attitude_rad: tuple[float, float] = (0.0, 0.0)  # the firmware's pitch, roll estimate
    tilt_trim_rad: tuple[float, float] = (0.0, 0.0)
    imu_ok: bool = False  # the IMU answered at boot and the last read succeeded
    imu_failures: int = 0  # failed IMU reads since boot
    board: str = DEFAULT_BOARD  # the board emulated (docs/BOARDS.md)


@dataclass
class _InFlight:
    """A set on the wire: its snapshot, the firmware's frame when it was asked for (sent then,
    or once the set before it was answered), the answers still to come (a set is several
    SET_PARAMS), whether one was a NAK."""

    snapshot: Snapshot
    asked_frame: int
    answers_due: int
    refused: bool = False


class EmulatedController:
    """One emulated board running the firmware, and what travels to it: the sets sent, their
    answers, the motion its gait got."""

    def __init__(self, pulses: FirmwarePulses, snapshot: Snapshot) -> None:
        self.pulses = pulses  # the firmware on the emulated MCU, one 20 ms frame per call
        self.built_version = snapshot.version  # the set compiled in as the firmware's defaults
        self.robot = snapshot.robot  # the robot whose legs and servos it was built for
        self._target = snapshot  # the set in force on the MCU
        self._motion = snapshot.motion  # what its gait got in the last frame (ramped, as its own)
        self._in_flight: deque[_InFlight] = deque()  # the set on the wire (one at most)
        # the newest set, to go once the wire is free, and the frame it was asked in
        self._waiting: tuple[Snapshot, int] | None = None
        self._skipped = 0
        # acknowledged sets not yet reached: (first frame, snapshot)
        self._scheduled: deque[tuple[int, Snapshot]] = deque()
        self._busy: deque[int] = deque(maxlen=BUSY_WINDOW_FRAMES)
        self._naks = 0
        #: the Mega board's last frame (its PCA9685 channels, its I2C transactions), else None
        self.board_frame: BoardFrame | None = None

    @classmethod
    def boot(
        cls,
        snapshot: Snapshot,
        hardware: HardwareSetup,
        geometry: LegGeometry = ARTRO_LEG,
        fsr_positions_m: Any = None,
        board: str = DEFAULT_BOARD,
    ) -> EmulatedController:
        """Build the firmware for `board` with the snapshot's set as its defaults and boot it
        (seconds on a cold cache, then milliseconds). ValueError if the set names an engine the
        firmware does not run, or a board it is not built for; BuildError or EmulatorError if
        the tool chain or the emulator fail."""
        check_board(board)
        if snapshot.gait.engine != FIRMWARE_ENGINE:
            raise ValueError(
                f"the firmware runs the {FIRMWARE_ENGINE} gait engine; the current set names "
                f"{snapshot.gait.engine!r}: choose engine {FIRMWARE_ENGINE} first"
            )
        doc = snapshot.parameter_set().to_dict()
        kind = FirmwarePulses if board == DEFAULT_BOARD else MegaPulses
        pulses = kind(
            doc,
            calibration=hardware.calibration,
            tdm=hardware.tdm,
            geometry=geometry,
            fsr_positions_m=fsr_positions_m,
        )
        return cls(pulses, snapshot)

    def send(self, snapshot: Snapshot, asked_frame: int | None = None) -> None:
        """The whole set over the UART (the protocol's SET_PARAMS); it reaches the frame the
        firmware's ACK names. One set is on the wire at a time, as `artro link` sends them:
        a newer version waits for it and replaces any that waited (a slider's drag, 150 law
        switches in 2 s, each sent whole had kept the MCU replaying stale sets for 13 s). Its
        latency counts from `asked_frame` (default: now)."""
        asked = self.pulses.frame if asked_frame is None else asked_frame
        if self._in_flight:
            if self._waiting is not None:
                self._skipped += 1
            self._waiting = (snapshot, asked)
            return
        parts = self.pulses.send_parameters(snapshot.parameter_set().to_dict())
        self._in_flight.append(_InFlight(snapshot, asked, parts))

    def next_pins(self) -> tuple[PinFrame, list[str], list[int]]:
        """Run the MCU through its next frame: the pins, problems to report, and per set that
        was acknowledged the frames from its sending to the first frame it reached."""
        frame = self.pulses.next_frame()
        if isinstance(self.pulses, MegaPulses):
            self.board_frame = self.pulses.board_frame
        problems, latencies = [], []
        for reply in frame.replies:
            if not self._in_flight or not isinstance(reply, proto.Ack | proto.Nak):
                continue
            entry = self._in_flight[0]
            entry.answers_due -= 1
            if isinstance(reply, proto.Nak) and not entry.refused:
                entry.refused = True
                self._naks += 1
                problems.append(
                    f"the firmware refused parameter version {entry.snapshot.version}: {reply}"
                )
            if entry.answers_due > 0:
                continue
            self._in_flight.popleft()
            if isinstance(reply, proto.Ack) and not entry.refused:  # the last part: whole set
                self._scheduled.append((reply.effective_frame, entry.snapshot))
                latencies.append(reply.effective_frame - entry.asked_frame + 1)
            if self._waiting is not None:  # the wire is free: the newest set goes
                (waiting, asked), self._waiting = self._waiting, None
                self.send(waiting, asked)
        while self._scheduled and self._scheduled[0][0] <= frame.index:
            _, self._target = self._scheduled.popleft()
        if frame.index > 0:  # the firmware's ramp takes one step per planned frame (ramp.c)
            target = self._target
            self._motion = ramp_motion(self._motion, target.motion, target.gait, FRAME_S)
        self._busy.append(frame.busy_cycles)
        pins = PinFrame(
            phase=frame.phase_rad,
            ocr=frame.ocr,
            edges=frame.edges,
            saturated_servos=frame.saturated,
            gamma_clamped=frame.gamma_clamped,
            motion=self._motion,
        )
        return pins, problems, latencies

    def sense(self, reading: SensorReading) -> None:
        """What the simulated sensors read after a frame: the emulated IMU and ADC hold it for
        the firmware's next read (docs/DESIGN.md §15)."""
        self.pulses.feed(reading)

    def status(self) -> FirmwareStatus:
        mcu = self.pulses.mcu
        law = read_law_output(mcu)
        sense = mcu.read_symbol("g_sensor_status")[0]
        return FirmwareStatus(
            laws_on=tuple(laws_on(self._target.gait)),
            attitude_rad=(float(law.attitude_rad[0]), float(law.attitude_rad[1])),
            tilt_trim_rad=(float(law.tilt_rad[0]), float(law.tilt_rad[1])),
            imu_ok=bool(sense & proto.IMU_PRESENT) and not sense & proto.IMU_STALE,
            imu_failures=mcu.read_symbol("g_imu_failures")[0],
            mcu_frame=self.pulses.frame,
            busy_cycles_last=self._busy[-1] if self._busy else 0,
            busy_cycles_max=max(self._busy, default=0),
            params_version_acked=self._target.version,
            sets_in_flight=len(self._in_flight),
            sets_skipped=self._skipped,
            naks=self._naks,
            board=self.board,
        )

    @property
    def board(self) -> str:
        return self.pulses.mcu.board

    @property
    def trace(self) -> MegaTrace | None:
        """The Mega board's last frames (for a VCD), else None."""
        return self.pulses.trace if isinstance(self.pulses, MegaPulses) else None

    def close(self) -> None:
        self.pulses.close()
