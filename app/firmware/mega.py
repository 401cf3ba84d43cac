"""The Mega 2560 + PCA9685 build emulated closed loop (docs/BOARDS.md): the firmware walks the
simulated robot through its emulated PCA9685 and reads the simulated IMU on the same I2C bus.
Each PCA9685 period's pulse on each channel, measured from its output edges in simulated time, is
compared with the model's pulse of the frame the period carries (the frame whose write was the
last STOP before the period began); the bus traffic is counted per frame at 400 kHz."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from app.firmware.build import build_firmware, wiring
from app.firmware.closed_loop import document_from_values, gyro_offset, model_closed_loop
from app.firmware.emulator import FRAME_CYCLES, Mcu, read_active_plan
from app.firmware.i2c import F_CPU_HZ, IMU_ADDRESS, PCA9685_ADDRESS, Transactions
from app.firmware.sensor_feed import RawSample, at_rest, raw_of, sample_of
from app.firmware.vcd_mega import mega_vcd_text
from app.robots.model import RobotModel
from app.sim.frame_loop import FrameLoop
from app.sim.frame_record import PinFrame
from app.worlds.variations import NOMINAL, Variation
from gait import GaitParams, Motion
from hardware import frame_edges, frame_ocr, servo_frame_ocr
from hardware.firmware.schema import values_from_document

MEGA = "mega2560-pca9685"
FRAME_S = 0.02
PRESCALE = 121
STEP_S = (PRESCALE + 1) / 25e6  # 4.88 us: the tolerance of every pulse
LED0_ON_L = 0x06
_TDM_OVERRUN, _PCA_REFUSED, _IMU_STALE = 0x01, 0x02, 0x02  # tdm.h, sensors.h
_PLAN_TICK = 100


def pca_steps(servo_ocr: NDArray[np.integer]) -> NDArray[np.int64]:
    """The firmware's OFF value of a servo's OCR (pca9685.h): (h * 6715 + 2^15) >> 16."""
    return (np.asarray(servo_ocr, np.int64) + 1) * 6715 + 32768 >> 16


Pulses = list[tuple[NDArray[np.int64], NDArray[np.int64]]]


def channel_pulses(
    cycles: NDArray[np.uint64],
    lines: NDArray[np.uint8],
    levels: NDArray[np.uint8],
    channels: int = 12,
) -> Pulses:
    """Per channel, (rise cycle, high cycles) of each whole pulse in the edges."""
    out = []
    for n in range(channels):
        mine = lines == n
        c, v = cycles[mine].astype(np.int64), levels[mine]
        rises = np.flatnonzero(v == 1)
        rises = rises[rises + 1 < len(v)]
        out.append((c[rises], c[rises + 1] - c[rises]))
    return out


@dataclass
class MegaRun:
    """A closed-loop run of the Mega build against the model."""

    frames: int = 0
    periods: int = 0  # PCA9685 periods compared
    pulses: int = 0  # channel pulses compared
    pulse_error_max_s: float = 0.0  # |PCA9685 pulse - model pulse|, the largest
    step_mismatches: int = 0  # pulses not the model's OFF steps exactly
    #: pulses not the OFF steps of the firmware's own OCR: the output stage's exactness (0)
    output_mismatches: int = 0
    frames_never_output: list[int] = field(default_factory=list)
    repeated_frames: list[int] = field(default_factory=list)  # carried by two periods
    bus_s: list[float] = field(default_factory=list)  # per frame, at 400 kHz
    bus_bytes: list[int] = field(default_factory=list)  # per frame
    #: per frame, each transaction's (address, first register, bytes)
    transactions: list[list[tuple[int, int, int]]] = field(default_factory=list)
    #: each frame's PCA9685 write ended (at 400 kHz) before its IMU read began
    write_before_read: bool = True
    busy_max: float = 0.0  # the largest share of a frame the CPU was awake
    overrun: bool = False
    refused_writes: bool = False  # a PCA9685 write found the bus taken
    imu_stale_frames: list[int] = field(default_factory=list)
    fell: bool = False
    flash_bytes: int = 0
    sram_bytes: int = 0
    flash_size: int = 0
    sram_size: int = 0
    #: with `trace`: the VCD of the run (app.firmware.vcd_mega)
    vcd: str = ""

    def failures(self) -> list[str]:
        said = []
        if self.pulse_error_max_s > STEP_S:
            said.append(f"a pulse differs from the model by {self.pulse_error_max_s * 1e6:.2f} us "
                        f"(more than one PCA9685 step, {STEP_S * 1e6:.2f} us)")  # fmt: skip
        if self.output_mismatches:
            said.append(f"{self.output_mismatches} pulses are not the firmware's own OFF steps")
        if self.frames_never_output:
            said.append(f"frames never on the PCA9685: {self.frames_never_output[:5]}")
        if self.overrun:
            said.append("a plan was late and a frame repeated (the overrun flag)")
        if self.refused_writes:
            said.append("a PCA9685 write found the bus taken")
        if not self.write_before_read:
            said.append(
                "a frame's PCA9685 write would still run at 400 kHz when the IMU read starts"
            )
        return said

    def summary(self) -> dict[str, Any]:
        worst = max(self.bus_s, default=0.0)
        return {
            "board": MEGA, "frames": self.frames, "periods": self.periods, "pulses": self.pulses,
            "pulse_error_max_us": self.pulse_error_max_s * 1e6, "step_us": STEP_S * 1e6,
            "step_mismatches": self.step_mismatches,
            "output_mismatches": self.output_mismatches,
            "repeated_frames": self.repeated_frames,
            "i2c_bus_ms_per_frame_max": worst * 1e3,
            "i2c_bus_share_max": worst / FRAME_S, "i2c_margin": 1.0 - worst / FRAME_S,
            "i2c_bytes_per_frame_max": max(self.bus_bytes, default=0),
            "i2c_transactions_frame_1": self.transactions[1] if len(self.transactions) > 1 else [],
            "cpu_busy_share_max": self.busy_max, "overrun": self.overrun,
            "imu_stale_frames": self.imu_stale_frames, "fell": self.fell,
            "flash_bytes": self.flash_bytes, "flash_size_bytes": self.flash_size,
            "sram_bytes": self.sram_bytes, "sram_size_bytes": self.sram_size,
            "ok": not self.failures(), "failures": self.failures(),
        }  # fmt: skip


def _frame_of(mcu: Mcu, cycle: int) -> int:
    """The frame a transaction belongs to; frame 0's write starts just before its clock."""
    return max(0, (int(cycle) - mcu.t0_cycle) // FRAME_CYCLES)


def run_mega_closed_loop(
    doc: dict[str, Any], frames: int, robot: RobotModel | None = None,
    variation: Variation = NOMINAL,
    *,
    trace: bool = False,
) -> MegaRun:  # fmt: skip
    """Walk the simulated `robot` for `frames` frames with the Mega build for `doc`, then compare
    every PCA9685 pulse with the model fed the counts the firmware read; `trace`: keep the
    PCA9685's edges and the transactions as VCD text (`MegaRun.vcd`)."""
    robot = robot or RobotModel.load()
    hardware = robot.hardware()
    tdm = hardware.tdm
    cmap = tdm.channel_map
    build = build_firmware(doc, board=MEGA, **wiring(robot))
    run = MegaRun(flash_bytes=build.flash_bytes, sram_bytes=build.sram_bytes,
                  flash_size=build.flash_size, sram_size=build.sram_size)  # fmt: skip
    loop = FrameLoop(robot, GaitParams.from_dict(doc["gait"]), Motion(**doc["motion"]),
                     hardware=hardware, variation=variation)  # fmt: skip
    loop.watch_sensors = True
    raw = at_rest()
    used: list[RawSample] = []  # samples the firmware read
    writes: list[tuple[int, int]] = []  # (stop cycle, frame) of each PCA write
    pulses: list[tuple[int, NDArray[np.int64]]] = []  # (period start cycle, high cycles (12,))
    own_ocr: list[NDArray[np.int64]] = []  # the firmware's servo OCR, per frame
    traced: list[tuple[tuple[NDArray, NDArray, NDArray], Transactions]] = []
    with Mcu(build.elf, sensors=sample_of(raw), board=MEGA) as mcu:
        assert mcu.i2c is not None
        offset = gyro_offset(mcu)
        mcu.i2c.take_transactions()  # the boot's (frame 0's write starts as the clock does)
        mcu.i2c.take_periods()
        busy = mcu.busy_cycles
        for k in range(frames):
            served = raw
            mcu.run_to_frame(k, _PLAN_TICK)
            plan = read_active_plan(mcu)
            own_ocr.append(plan.servo_ocr)
            mcu.run_to_frame(k + 1, _PLAN_TICK)
            flags = mcu.read_symbol("g_tdm_flags")[0]
            run.overrun |= bool(flags & _TDM_OVERRUN)
            run.refused_writes |= bool(flags & _PCA_REFUSED)
            if mcu.read_symbol("g_sensor_status")[0] & _IMU_STALE:
                run.imu_stale_frames.append(k)
                served = dataclasses.replace(served, accel=used[-1].accel, gyro=used[-1].gyro)
            used.append(served)
            now = mcu.busy_cycles
            run.busy_max = max(run.busy_max, (now - busy) / FRAME_CYCLES)
            busy = now
            bus = mcu.i2c.take_transactions()
            _count_bus(mcu, bus, run, writes)
            cycles, lines, levels = mcu.i2c.take_edges()
            if trace:
                traced.append(((cycles, lines, levels), bus))
            periods = mcu.i2c.take_periods()
            high = np.full((len(periods.start_cycle), 12), -1, np.int64)
            for n, (rise, width) in enumerate(channel_pulses(cycles, lines, levels)):
                where = np.searchsorted(periods.start_cycle.astype(np.int64), rise)
                ok = (where < len(high)) & (
                    periods.start_cycle[np.minimum(where, len(high) - 1)] == rise
                )
                high[where[ok], n] = width[ok]
            pulses += [(int(s), high[i]) for i, s in enumerate(periods.start_cycle)]
            # the simulated servos: the last period begun in this frame, in the TDM layout
            in_frame = [h for s, h in pulses if mcu.frame_start(k) <= s < mcu.frame_start(k + 1)]
            width_us = in_frame[-1] / (F_CPU_HZ / 1e6) if in_frame else None
            pulsed = width_us is not None and bool((width_us > 0).all())
            ocr = (
                frame_ocr(width_us, tdm) if pulsed and width_us is not None else plan_ocr(plan, tdm)
            )
            pins = PinFrame(plan.phase_rad, ocr, frame_edges(ocr, tdm), np.zeros(12, bool), False,
                            Motion(**doc["motion"]))  # fmt: skip
            record = loop.step_pins(pins)
            run.fell |= loop.fell
            assert record.reading is not None  # watch_sensors
            raw = raw_of(record.reading)
            mcu.set_sensors(sample_of(raw))
        if trace:
            pwm = tuple(np.concatenate([t[0][i] for t in traced]) for i in range(3))
            bus = Transactions(*(np.concatenate([getattr(t[1], f) for t in traced])
                                 for f in Transactions.__dataclass_fields__))  # fmt: skip
            run.vcd = mega_vcd_text(pwm, bus, mcu.t0_cycle, comment=f"{frames} frames")  # type: ignore[arg-type]  # 3 arrays
    run.frames = frames
    docs = [document_from_values(values_from_document(doc)) for _ in range(frames + 1)]
    model, _ = model_closed_loop(docs, used, offset, hardware, robot)
    model_ocr = model.ocr[..., cmap.channel_index, cmap.slot_index].astype(np.int64)
    _compare(run, pulses, writes, model_ocr, np.array(own_ocr, np.int64), frames)
    return run


def plan_ocr(plan: Any, tdm: Any) -> NDArray[np.int32]:
    """The firmware's own OCR of the frame in the TDM layout (before the PCA9685 has a pulse)."""
    return servo_frame_ocr(plan.servo_ocr.astype(np.int32), tdm)


def _count_bus(mcu: Mcu, got: Transactions, run: MegaRun, writes: list[tuple[int, int]]) -> None:
    frame_of = np.array([_frame_of(mcu, s) for s in got.start_cycle], np.int64)
    for k in np.unique(frame_of):
        mine = got.select(frame_of == k)
        while len(run.bus_s) <= k:
            run.bus_s.append(0.0)
            run.bus_bytes.append(0)
            run.transactions.append([])
        run.bus_s[k] += float(mine.bus_s().sum())
        run.bus_bytes[k] += int(mine.bytes.sum())
        said = zip(mine.address, mine.register, mine.bytes, strict=True)
        run.transactions[k] += [(int(a), int(r), int(b)) for a, r, b in said]
        pca = np.flatnonzero((mine.address == PCA9685_ADDRESS) & (mine.register == LED0_ON_L))
        imu = np.flatnonzero(mine.address == IMU_ADDRESS)
        for i in pca:
            writes.append((int(mine.stop_cycle[i]), int(k)))
            end = int(mine.start_cycle[i]) + mine.bus_s()[i] * F_CPU_HZ
            if len(imu) and end > int(mine.start_cycle[imu[0]]):
                run.write_before_read = False


def _compare(
    run: MegaRun,
    pulses: list[tuple[int, NDArray[np.int64]]],
    writes: list[tuple[int, int]],
    model_ocr: NDArray[np.int64],
    own_ocr: NDArray[np.int64],
    frames: int,
) -> None:
    stops = np.array([s for s, _ in writes], np.int64)
    carried: dict[int, int] = {}
    for start, high in pulses:
        i = np.searchsorted(stops, start) - 1  # the last write whose STOP came before
        if i < 0:
            continue
        frame = writes[i][1]
        if frame >= frames:
            continue
        carried[frame] = carried.get(frame, 0) + 1
        want_ocr = model_ocr[frame]
        want_s = (want_ocr + 1) * 0.5e-6
        got_s = high / F_CPU_HZ
        run.pulse_error_max_s = max(run.pulse_error_max_s, float(np.max(np.abs(got_s - want_s))))
        want_steps_s = pca_steps(want_ocr) * STEP_S
        run.step_mismatches += int(np.sum(np.abs(got_s - want_steps_s) > 1.5 / F_CPU_HZ))
        own_steps_s = pca_steps(own_ocr[frame]) * STEP_S
        run.output_mismatches += int(np.sum(np.abs(got_s - own_steps_s) > 1.5 / F_CPU_HZ))
        run.periods += 1
        run.pulses += len(high)
    run.frames_never_output = [k for k in range(frames - 1) if k not in carried]
    run.repeated_frames = sorted(k for k, n in carried.items() if n > 1)
