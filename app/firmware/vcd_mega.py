"""The Mega board's lines as a Value Change Dump (docs/BOARDS.md): the PCA9685's servo channels
PWM0..PWM11, and I2C_PCA9685 / I2C_MPU6050 high from START to STOP of a transaction to that part
(one-bit wires: sigrok's VCD input reads no vectors); 100 ns units from frame 0's start, a CPU
cycle rounded to the nearest (10 MHz, as vcd.py). Bus times are the emulator's (simavr's TWI:
9 us a byte); `app.firmware.i2c` counts them at 400 kHz."""

from __future__ import annotations

from datetime import UTC, datetime

import numpy as np
from numpy.typing import NDArray

from app.firmware.i2c import IMU_ADDRESS, PCA9685_ADDRESS, Transactions

SERVO_CHANNELS = 12
TIMESCALE = "100ns"


def mega_vcd_text(
    pwm: tuple[NDArray[np.uint64], NDArray[np.uint8], NDArray[np.uint8]],
    bus: Transactions,
    t0_cycle: int,
    *,
    comment: str = "",
) -> str:
    """The VCD text of the PCA9685's edges `pwm` (cycle, channel, level) and the transactions."""
    parts = {PCA9685_ADDRESS: "I2C_PCA9685", IMU_ADDRESS: "I2C_MPU6050"}
    names = [f"PWM{n}" for n in range(SERVO_CHANNELS)] + list(parts.values())
    codes = [chr(ord("!") + i) for i in range(len(names))]
    code_of = dict(zip(parts, codes[SERVO_CHANNELS:], strict=True))
    events: list[tuple[int, int, str]] = []  # (cycle, order, text)
    cycles, lines, levels = pwm
    for c, line, level in zip(cycles.tolist(), lines.tolist(), levels.tolist(), strict=True):
        if line < SERVO_CHANNELS:
            events.append((c, 1, f"{level}{codes[line]}"))
    for start, stop, address in zip(
        bus.start_cycle.tolist(), bus.stop_cycle.tolist(), bus.address.tolist(), strict=True
    ):
        if address in code_of:
            events += [(start, 0, f"1{code_of[address]}"), (stop, 2, f"0{code_of[address]}")]
    events.sort(key=lambda e: (e[0], e[1]))
    out = [
        f"$date {datetime.now(UTC).isoformat(timespec='seconds')} $end",
        "$version artro-gait-studio $end",
    ]
    if comment:
        out.append(f"$comment {comment} $end")
    out += [f"$timescale {TIMESCALE} $end", "$scope module mega2560_pca9685 $end"]
    out += [f"$var wire 1 {c} {n} $end" for c, n in zip(codes, names, strict=True)]
    out += ["$upscope $end", "$enddefinitions $end", "#0", "$dumpvars"]
    out += [f"0{c}" for c in codes] + ["$end"]
    last = 0
    for cycle, _, text in events:
        t = (max(int(cycle) - t0_cycle, 0) * 5 + 4) // 8  # 0.625 units a cycle, rounded
        if t != last:
            out.append(f"#{t}")
            last = t
        out.append(text)
    return "\n".join(out) + "\n"
