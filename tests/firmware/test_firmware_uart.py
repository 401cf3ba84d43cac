"""The emulated UART times a byte as the chip does (app/firmware/harness_fixes.c,
FIX_UART_BYTE_TIME): at 57600 baud with U2X0 a byte is 10 bits of 35 × 8 cycles, and a walk's
SENSORS stream, one a frame, loses nothing. simavr's own timing (the correction left out) loses
one frame in three."""

from __future__ import annotations

import numpy as np

from app.firmware import protocol as proto
from app.firmware.build import build_firmware
from app.firmware.emulator import Mcu
from app.firmware.sensor_feed import at_rest, sample_of
from tests.testing.firmware_support import preset

CHIP_BYTE_CYCLES = 10 * (34 + 1) * 8  # start, 8 data, stop; UBRR 34 with U2X0 at 16 MHz
SIMAVR_BYTE_CYCLES = 11 * (34 + 1) * 16  # U2X0 missed, a parity bit counted


def walk_sensors(mcu: Mcu, frames: int) -> tuple[list[int], float]:
    """The frame numbers of the SENSORS a walk of `frames` sends, and the median cycles between
    the bytes of one message."""
    mcu.run_to_frame(3)
    mcu.send(proto.telemetry_on(2))
    mcu.send(proto.command(proto.Msg.START))
    mcu.run_to_frame(10)
    mcu.take_uart()
    mcu.run_to_frame(10 + frames)
    cycles, data = mcu.take_uart()
    sent = [proto.parse(m) for m in proto.Decoder().feed(data) if m.type == proto.Msg.SENSORS]
    gaps = np.diff(cycles.astype(np.int64))
    return [s.frame for s in sent], float(np.median(gaps))


def test_a_walk_sends_its_sensors_every_frame_at_the_chips_byte_time() -> None:
    elf = build_firmware(preset("robust", a_p=0.05)).elf
    with Mcu(elf, sensors=sample_of(at_rest())) as mcu:
        frames, byte_cycles = walk_sensors(mcu, 30)
    assert byte_cycles == CHIP_BYTE_CYCLES
    assert len(frames) >= 29 and frames == list(range(frames[0], frames[0] + len(frames)))


def test_without_the_correction_the_line_is_slower_and_frames_are_lost() -> None:
    elf = build_firmware(preset("robust", a_p=0.05)).elf
    with Mcu(elf, sensors=sample_of(at_rest()), fix_uart_byte_time=False) as mcu:
        frames, byte_cycles = walk_sensors(mcu, 30)
    assert byte_cycles == SIMAVR_BYTE_CYCLES
    assert len(frames) <= 22  # 2 of every 3
