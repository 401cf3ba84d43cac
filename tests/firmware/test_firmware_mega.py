"""The Mega 2560 + PCA9685 board (docs/BOARDS.md): its build, the PCA9685 the firmware sets up on
the emulated I2C bus, a closed-loop walk whose every pulse is the model's within one PCA9685
step, the bus traffic per frame, and the .hex as avrdude would upload it."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest

from app.firmware.build import BOARD_MEMORY, build_firmware, wiring
from app.firmware.emulator import FRAME_CYCLES, Mcu
from app.firmware.i2c import BUS_HZ, IMU_ADDRESS, PCA9685_ADDRESS
from app.firmware.mega import MEGA, STEP_S, channel_pulses, run_mega_closed_loop
from app.firmware.sensor_feed import at_rest, sample_of
from app.robots.model import RobotModel
from tests.testing.firmware_support import preset

#: 4096 steps of 122 / 25 MHz in 16 MHz cycles: 319 815.68
PERIOD_CYCLES = 4096 * 122 * 16 / 25
#: a frame's bus: the PCA9685 write (SLA+W, LED0_ON_L, 48 bytes) and the IMU burst (SLA+W,
#: ACCEL_XOUT_H, SLA+R, 14 bytes), 9 clocks a byte, START/STOP/repeated START one each
FRAME_BUS_S = (9 * 50 + 2 + 9 * 17 + 3) / BUS_HZ  # 1.52 ms


@pytest.fixture(scope="module")
def robot() -> RobotModel:
    return RobotModel.load()


@pytest.fixture(scope="module")
def doc(robot: RobotModel) -> dict:
    return preset(robot.description.default_preset)  # ArtRo's robust: laws on, closed loop


def test_both_boards_build_and_the_mega_fits_its_memory(robot: RobotModel, doc: dict) -> None:
    mega = build_firmware(doc, board=MEGA, **wiring(robot))
    default = build_firmware(doc, **wiring(robot))
    assert (mega.flash_size, mega.sram_size) == BOARD_MEMORY[MEGA] == (256 * 1024, 8 * 1024)
    assert 0 < mega.flash_bytes < mega.flash_size and 0 < mega.sram_bytes < mega.sram_size
    arch = {
        b.board: subprocess.run(
            ["avr-objdump", "-f", str(b.elf)], capture_output=True, text=True, check=True
        ).stdout
        for b in (mega, default)
    }
    assert "architecture: avr:6" in arch[MEGA]  # the ATmega2560's core
    assert "architecture: avr:51" in arch["artro-atmega128"]
    # the default is the ATmega128, its build as it was keyed before boards
    assert build_firmware(doc, board="artro-atmega128", **wiring(robot)).elf == default.elf
    with pytest.raises(ValueError, match="builds for artro-atmega128, mega2560-pca9685"):
        build_firmware(doc, board="uno", **wiring(robot))


def test_the_firmware_sets_the_pca9685_up_as_the_datasheet_says(
    robot: RobotModel, doc: dict
) -> None:
    build = build_firmware(doc, board=MEGA, **wiring(robot))
    with Mcu(build.elf, sensors=sample_of(at_rest()), board=MEGA) as mcu:
        assert mcu.i2c is not None
        boot = mcu.i2c.take_transactions()
        mcu.run_to_frame(4)
        bus, periods = mcu.i2c.take_transactions(), mcu.i2c.take_periods()
        mode1, mode2, prescale = (mcu.i2c.register(r) for r in (0x00, 0x01, 0xFE))
    # sleep (SLEEP | AI), PRESCALE while asleep, wake (AI), all channels full OFF: then frame 0
    pca = boot.select(boot.address == PCA9685_ADDRESS)
    assert list(pca.register[:4]) == [0x00, 0xFE, 0x00, 0x06] and list(pca.bytes[:4]) == [
        3,
        3,
        3,
        50,
    ]
    assert (mode1, mode2, prescale) == (0x20, 0x04, 121)  # awake, auto-increment; totem pole
    assert set(periods.prescale) == {121}
    gaps = np.diff(periods.start_cycle.astype(np.int64))
    assert set(gaps) <= {int(PERIOD_CYCLES), int(PERIOD_CYCLES) + 1}  # its own 25 MHz clock
    assert abs(gaps.mean() - PERIOD_CYCLES) < 1.0
    assert periods.step_s()[0] == pytest.approx(4.88e-6)
    assert bus.acked.all() and set(bus.address) == {PCA9685_ADDRESS, IMU_ADDRESS}


def test_a_closed_loop_walk_puts_every_pulse_within_one_step(robot: RobotModel, doc: dict) -> None:
    run = run_mega_closed_loop(doc, 150, robot)
    assert run.failures() == []
    assert run.periods >= 149 and run.pulses == 12 * run.periods
    assert run.pulse_error_max_s <= STEP_S / 2 + 2 / 16e6  # rounding to a step, edges to a cycle
    assert run.step_mismatches == 0  # every pulse is the firmware's OFF value of the model's OCR
    assert run.output_mismatches == 0  # ... and of the firmware's own OCR of that frame
    assert run.frames_never_output == [] and not run.overrun and not run.fell
    # each frame: the PCA9685 write at its start, then the IMU burst in slot 3
    assert all(
        t == [(PCA9685_ADDRESS, 0x06, 50), (IMU_ADDRESS, 0x3B, 17)] for t in run.transactions
    )
    assert max(run.bus_s) == pytest.approx(FRAME_BUS_S) and FRAME_BUS_S < 0.1 * 0.020
    assert run.write_before_read and run.imu_stale_frames == []
    assert run.busy_max < 0.6  # the CPU awake for less than 60 % of any frame


@pytest.mark.slow
def test_a_frame_shows_twice_where_the_periods_slip_past_the_frames(
    robot: RobotModel, doc: dict
) -> None:
    """19.988 ms periods against 20 ms frames: every ~1660 frames a period starts before that
    frame's write ends and repeats the last frame's pulses; no frame is lost."""
    run = run_mega_closed_loop(doc, 1800, robot)
    assert run.failures() == []
    assert 1 <= len(run.repeated_frames) <= 2 and run.frames_never_output == []
    assert run.periods >= 1799 and run.output_mismatches == 0


def test_the_hex_read_back_boots_in_simavr_as_the_elf_does(
    robot: RobotModel, doc: dict, tmp_path: Path
) -> None:
    """What `artro firmware flash` uploads: the .hex, turned back into an image simavr boots."""
    build = build_firmware(doc, board=MEGA, **wiring(robot))
    image = tmp_path / "from_hex.elf"
    subprocess.run(["avr-objcopy", "-I", "ihex", "-O", "elf32-avr", "--rename-section",
                    ".sec1=.text", str(build.hex), str(image)], check=True)  # fmt: skip
    widths = []
    for elf in (build.elf, image):
        with Mcu(elf, sensors=sample_of(at_rest()), board=MEGA) as mcu:
            mcu.run_to_frame(6)
            assert mcu.i2c is not None
            edges = mcu.i2c.take_edges()
            widths.append([w for _, w in channel_pulses(*edges)])
    assert all(len(w) >= 4 for w in widths[0])
    for from_elf, from_hex in zip(*widths, strict=True):
        assert np.array_equal(from_elf, from_hex)
    assert FRAME_CYCLES == 320_000


PART_PROGRAM = r"""
#include <avr/interrupt.h>
#include <avr/io.h>
#include "twi.h"
static void w(uint8_t reg, const uint8_t *d, uint8_t n) { twi_blocking(0x40, reg, d, n, 0, 0); }
int main(void)
{
    static const uint8_t wake[1] = {0x01}, pre[1] = {50}, led0[4] = {0x11, 0x22, 0x33, 0x44};
    static const uint8_t ai[1] = {0x21}, all_off[2] = {0x00, 0x01};
    sei();
    twi_init();
    w(0x00, wake, 1);      /* awake, no auto-increment */
    w(0xFE, pre, 1);       /* refused: the oscillator runs */
    w(0x06, led0, 4);      /* no auto-increment: every byte into LED0_ON_L */
    w(0x00, ai, 1);        /* auto-increment */
    w(0xFC, all_off, 2);   /* ALL_LED_OFF = 256: every channel's OFF */
    TCCR1B = _BV(CS10);    /* the harness waits for a timer */
    for (;;) {}
}
"""


def test_the_pca9685_part_keeps_the_datasheets_rules(tmp_path: Path) -> None:
    """Beyond what the firmware uses: PRE_SCALE refused while awake, no auto-increment without AI,
    ALL_LED_OFF into every channel, the period at another PRESCALE (30, the power-on value)."""
    source = tmp_path / "part.c"
    source.write_text(PART_PROGRAM, encoding="ascii")
    src = Path(__file__).resolve().parents[2] / "hardware" / "firmware" / "src"
    elf = tmp_path / "part.elf"
    subprocess.run(["avr-gcc", "-mmcu=atmega2560", "-DF_CPU=16000000UL", "-Os", f"-I{src}",
                    str(source), str(src / "twi.c"), "-o", str(elf)], check=True)  # fmt: skip
    with Mcu(elf, board=MEGA) as mcu:
        assert mcu.i2c is not None
        mcu.run_until(mcu.cycle + 16_000 * 30)
        registers = [mcu.i2c.register(r) for r in (0x00, 0xFE, 0x06, 0x07, 0x08, 0x09, 0x44)]
        periods = mcu.i2c.take_periods()
        cycles, lines, levels = mcu.i2c.take_edges()
    assert registers == [0x21, 30, 0x44, 0x00, 0x00, 0x01, 0x00]
    assert set(periods.prescale) == {30}
    assert set(np.diff(periods.start_cycle.astype(np.int64))) <= {81264, 81265}  # 4096 * 31 steps
    step_cycles = 31 * 16 / 25
    widths = channel_pulses(cycles, lines, levels, channels=16)
    assert np.allclose(widths[0][1], (256 - 0x44) * step_cycles, atol=1)  # ON = 0x44, OFF = 256
    for n in range(1, 16):
        assert np.allclose(widths[n][1], 256 * step_cycles, atol=1) and len(widths[n][1]) >= 5
