"""The Mega 2560 + PCA9685 build as the firmware drive's pulse source (docs/BOARDS.md,
docs/DESIGN.md §5): per 20 ms frame the servos get the last PCA9685 period's pulses measured from
the part's output edges, in the TDM table's layout (as app/firmware/mega.py); the frame's
`BoardFrame` holds the channels' edges and the I2C transactions for the scope, and `MegaTrace`
the last frames' for a VCD (app/firmware/vcd_mega.py)."""

from __future__ import annotations

import dataclasses
import threading
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from app.firmware import protocol as proto
from app.firmware.emulator import FRAME_CYCLES, read_active_plan
from app.firmware.i2c import BUS_HZ, F_CPU_HZ, IMU_ADDRESS, PCA9685_ADDRESS, Transactions
from app.firmware.mega import MEGA, STEP_S, channel_pulses, plan_ocr
from app.firmware.pulses import PLAN_GAMMA_CLAMPED, FirmwareFrame, FirmwarePulses
from app.firmware.vcd_mega import SERVO_CHANNELS, mega_vcd_text
from hardware import SERVO_NAMES, TdmConfig, frame_edges, frame_ocr

_PLAN_TICK = 100  # as pulses.py: the frame's plan is read just after its start
CYCLES_PER_US = F_CPU_HZ / 1e6
PART_NAMES = {PCA9685_ADDRESS: "PCA9685", IMU_ADDRESS: "MPU-6050"}
TRACE_FRAMES = 3000  # the frames a VCD carries: the recorder's 60 s
#: what the Mega's 2.5 ms slots do (mega_clock.c; SENSE_SLOT, COMPUTE_SLOT in config.h), the
#: scope frame's `slots`: the others only keep the clock
SLOT_TASKS = {0: "PCA9685 write", 3: "IMU + FSR read", 4: "plan next frame"}
SLOTS_PER_FRAME = 8
#: the PCA9685's own period (4096 steps of its 25 MHz oscillator) and its slip per 20 ms frame
PERIOD_US = 4096 * STEP_S * 1e6
FRAME_US = 20_000.0

PwmEdges = tuple[NDArray[np.uint64], NDArray[np.uint8], NDArray[np.uint8]]


def _empty_edges() -> PwmEdges:
    return np.empty(0, np.uint64), np.empty(0, np.uint8), np.empty(0, np.uint8)


def _empty_bus() -> Transactions:
    u8, u16 = np.empty(0, np.uint8), np.empty(0, np.uint16)
    return Transactions(np.empty(0, np.uint64), np.empty(0, np.uint64), u8, np.empty(0, bool),
                        np.empty(0, np.int16), u16, u8.copy(), np.empty(0, bool))  # fmt: skip


def _join_bus(parts: list[Transactions]) -> Transactions:
    fields = Transactions.__dataclass_fields__
    return Transactions(*(np.concatenate([getattr(p, f) for p in parts]) for f in fields))


@dataclass(frozen=True)
class BoardFrame:
    """One frame of the Mega board as the scope shows it: the PCA9685's servo channels (each
    one's level at the frame's start and its edges in the frame) and the I2C transactions that
    began in it, CPU cycles; JSON made only when asked (`message`)."""

    start_cycle: int  # the frame's start
    initial: NDArray[np.uint8]  # (12,) each channel's level at the start
    pwm: PwmEdges  # (cycle, channel, level) in the frame, oldest first
    pulse_us: NDArray[np.float64] | None  # (12,) the pulses the servos got; None: the plan's
    bus: Transactions
    #: the PCA9685's periods begun in the frame (CPU cycles): where its own clock has slipped to
    period_starts: NDArray[np.uint64] = dataclasses.field(
        default_factory=lambda: np.empty(0, np.uint64)
    )

    def message(self) -> dict[str, Any]:
        """The scope frame's `board`, `slots` (what each 2.5 ms slot does), `pca9685` (with its
        own period, its slip a frame and where its periods began) and `i2c` (times in µs from the
        frame's start;
        a transaction's `end_us` is its START plus its time on a 400 kHz bus, `emulated_stop_us`
        the emulator's STOP, simavr's TWI taking 9 µs a byte)."""
        us = lambda cycle: round((int(cycle) - self.start_cycle) / CYCLES_PER_US, 4)  # noqa: E731
        cycles, lines, levels = (a.tolist() for a in self.pwm)
        channels = []
        for n in range(SERVO_CHANNELS):
            edges = [[us(c), v] for c, line, v in zip(cycles, lines, levels, strict=True)
                     if line == n]  # fmt: skip
            pulse = None if self.pulse_us is None else round(float(self.pulse_us[n]), 4)
            channels.append({"channel": n, "name": f"PWM{n}", "servo": SERVO_NAMES[n],
                             "initial": int(self.initial[n]), "edges_us": edges,
                             "pulse_us": pulse})  # fmt: skip
        bus = self.bus
        bus_s = bus.bus_s()
        transactions = [
            {
                "address": int(bus.address[i]),
                "part": PART_NAMES.get(int(bus.address[i]), f"0x{int(bus.address[i]):02x}"),
                "write": bool(bus.write[i]),
                "register": None if bus.register[i] < 0 else int(bus.register[i]),
                "bytes": int(bus.bytes[i]),
                "restarts": int(bus.restarts[i]),
                "acked": bool(bus.acked[i]),
                "start_us": us(bus.start_cycle[i]),
                "end_us": round(us(bus.start_cycle[i]) + float(bus_s[i]) * 1e6, 4),
                "emulated_stop_us": us(bus.stop_cycle[i]),
            }
            for i in range(len(bus))
        ]
        return {
            "board": MEGA,
            "slots": [{"slot": k, "task": SLOT_TASKS.get(k)} for k in range(SLOTS_PER_FRAME)],
            "pca9685": {"address": PCA9685_ADDRESS, "step_us": STEP_S * 1e6, "channels": channels,
                        "period_us": round(PERIOD_US, 4),
                        "slip_us_per_frame": round(PERIOD_US - FRAME_US, 4),
                        "period_starts_us": [us(c) for c in self.period_starts.tolist()]},
            "i2c": {"bus_hz": BUS_HZ, "bus_us": round(float(bus_s.sum()) * 1e6, 4),
                    "transactions": transactions},
        }  # fmt: skip


class MegaTrace:
    """The last TRACE_FRAMES frames' PCA9685 edges and transactions, for a VCD; written by the
    simulation thread, read by any (under its lock)."""

    def __init__(self, frames: int = TRACE_FRAMES) -> None:
        self._frames: deque[BoardFrame] = deque(maxlen=frames)
        self._lock = threading.Lock()

    def add(self, frame: BoardFrame) -> None:
        with self._lock:
            self._frames.append(frame)

    def __len__(self) -> int:
        return len(self._frames)

    def vcd_text(self, comment: str = "") -> str:
        """The kept frames as VCD (vcd_mega.py), time 0 the first one's start; ValueError if
        none is kept."""
        with self._lock:
            frames = list(self._frames)
        return board_frames_vcd(frames, comment)


def board_frames_vcd(frames: list[BoardFrame], comment: str = "") -> str:
    """Consecutive frames of one Mega run as VCD (vcd_mega.py), time 0 the first one's start;
    ValueError if there are none."""
    if not frames:
        raise ValueError("no frame of the Mega board is kept yet")
    first = frames[0]
    high = np.flatnonzero(first.initial)  # a channel high as the trace starts rises at 0
    start = (np.full(len(high), first.start_cycle, np.uint64), high.astype(np.uint8),
             np.ones(len(high), np.uint8))  # fmt: skip
    pwm = tuple(np.concatenate([start[i]] + [f.pwm[i] for f in frames]) for i in range(3))
    bus = _join_bus([f.bus for f in frames])
    return mega_vcd_text(pwm, bus, first.start_cycle, comment=comment)  # type: ignore[arg-type]  # 3 arrays


def last_run(frames: list[BoardFrame]) -> list[BoardFrame]:
    """The frames of the last emulated run among `frames` (oldest first): a firmware drive
    started anew boots a new MCU, whose cycles count from 0 again."""
    begin = len(frames) - 1
    while begin > 0 and frames[begin - 1].start_cycle < frames[begin].start_cycle:
        begin -= 1
    return frames[max(begin, 0) :]


class MegaPulses(FirmwarePulses):
    """The Mega build on the emulated ATmega2560 with its PCA9685, advanced frame by frame; each
    frame's `BoardFrame` in `board_frame`, the last frames' in `trace`."""

    def __init__(self, doc: dict[str, Any], **kwargs: Any) -> None:
        """As FirmwarePulses, built and emulated for the mega2560-pca9685 board."""
        super().__init__(doc, board=MEGA, **kwargs)
        self.tdm: TdmConfig = kwargs.get("tdm") or TdmConfig()
        bus = self.mcu.i2c
        assert bus is not None  # the Mega's Mcu has its PCA9685
        self.i2c = bus
        bus.take_transactions()  # the boot's (frame 0's write starts as its clock does)
        bus.take_periods()
        self._edges: PwmEdges = bus.take_edges()  # taken, not yet in a frame
        self._bus = _empty_bus()
        self._periods = np.empty(0, np.uint64)  # period starts not yet in a frame
        self._level = np.zeros(SERVO_CHANNELS, np.uint8)
        self.board_frame: BoardFrame | None = None
        self.trace = MegaTrace()

    def next_frame(self) -> FirmwareFrame:
        k, mcu, tdm = self.frame, self.mcu, self.tdm
        mcu.run_to_frame(k, _PLAN_TICK)
        plan = read_active_plan(mcu)
        mcu.run_to_frame(k + 1, _PLAN_TICK)
        replies = tuple(r for r in self.link.poll() if not isinstance(r, proto.Telemetry))
        mcu.take_edges()  # the Mega's own pins: nothing the servos read
        start, end = mcu.frame_start(k), mcu.frame_start(k + 1)
        cycles, lines, levels = (np.concatenate([a, b]) for a, b in
                                 zip(self._edges, self.i2c.take_edges(), strict=True))  # fmt: skip
        servo = lines < SERVO_CHANNELS
        cycles, lines, levels = cycles[servo], lines[servo], levels[servo]
        order = np.argsort(cycles, kind="stable")
        cycles, lines, levels = cycles[order], lines[order], levels[order]
        periods = np.concatenate([self._periods, self.i2c.take_periods().start_cycle])
        self._periods = periods[periods >= end]
        begun = periods[(periods >= start) & (periods < end)]
        width_us = None
        if len(begun):  # the last period begun in the frame, as app/firmware/mega.py takes it
            rise_width = channel_pulses(cycles, lines, levels, SERVO_CHANNELS)
            high = np.full(SERVO_CHANNELS, -1, np.int64)
            for n, (rise, width) in enumerate(rise_width):
                hit = np.flatnonzero(rise == int(begun[-1]))
                if len(hit):
                    high[n] = width[hit[-1]]
            if (high > 0).all():
                width_us = high / CYCLES_PER_US
        ocr = plan_ocr(plan, tdm) if width_us is None else frame_ocr(width_us, tdm)
        here = cycles < end
        self._edges = (cycles[~here], lines[~here], levels[~here])
        pwm = (cycles[here], lines[here], levels[here])
        bus = _join_bus([self._bus, self.i2c.take_transactions()])
        frame_of = (bus.start_cycle.astype(np.int64) - mcu.t0_cycle) // FRAME_CYCLES
        self._bus = bus.select(frame_of > k)
        board = BoardFrame(start, self._level.copy(), pwm, width_us, bus.select(frame_of <= k),
                           begun)  # fmt: skip
        for line, level in zip(pwm[1].tolist(), pwm[2].tolist(), strict=True):
            self._level[line] = level
        self.board_frame = board
        self.trace.add(board)
        busy = mcu.busy_cycles
        frame = FirmwareFrame(
            k, plan.phase_rad, plan.angles, ocr, frame_edges(ocr, tdm), busy - self._busy,
            saturated=(plan.saturated >> np.arange(len(SERVO_NAMES))) & 1 == 1,
            gamma_clamped=bool(plan.flags & PLAN_GAMMA_CLAMPED), replies=replies,
        )  # fmt: skip
        self._busy = busy
        self.frame += 1
        return frame
