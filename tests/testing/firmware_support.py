"""Shared helpers of the firmware tests: preset documents, builds and emulators."""

from __future__ import annotations

import contextlib
import copy
import json
import math
import threading
from collections.abc import Iterator
from typing import Any

from app.assets import builtin_presets_dir
from app.firmware.build import build_firmware
from app.firmware.emulator import Mcu
from app.firmware.pty_bridge import PtyBridge
from app.firmware.sensor_feed import GYRO_ZERO_RATE_COUNTS, ONE_G_COUNTS, RawSample


def preset(name: str, **motion: float) -> dict[str, Any]:
    """A built-in preset's document, with motion-vector entries replaced."""
    doc = json.loads((builtin_presets_dir() / f"{name}.json").read_text(encoding="utf-8"))
    doc = copy.deepcopy(doc)
    doc["motion"].update(motion)
    return doc


def emulator(doc: dict[str, Any], **kwargs: Any) -> Mcu:
    """The firmware built for `doc` (cached), booted on simavr."""
    return Mcu(build_firmware(doc).elf, **kwargs)


def frames_for_cycles(doc: dict[str, Any], cycles: float) -> int:
    """Frames that cover `cycles` gait cycles at the document's clock frequency."""
    return int(cycles / (doc["gait"]["clock"]["freq_hz"] * 0.02)) + 1


@contextlib.contextmanager
def served_on_a_pty(mcu: Mcu, *, realtime: bool = False) -> Iterator[str]:
    """`mcu`'s UART on a pseudo-terminal (as fast as it runs, or paced to wall time as the
    robot runs) until the block ends: its path."""
    stop = threading.Event()
    bridge = PtyBridge(mcu, realtime=realtime)
    thread = threading.Thread(target=bridge.serve, args=(stop, 600.0), daemon=True)
    thread.start()
    try:
        yield bridge.port
    finally:
        stop.set()
        thread.join()
        bridge.close()


PITCH_RAD, ROLL_RAD = 0.12, -0.07  # the trunk as the emulated IMU sees it, still


def tilted() -> RawSample:
    """Still, leaning forward and to the right: the accelerometer's share of 1 g on each axis."""
    g = ONE_G_COUNTS
    accel = (
        round(-g * math.sin(PITCH_RAD)),
        round(g * math.cos(PITCH_RAD) * math.sin(ROLL_RAD)),
        round(g * math.cos(PITCH_RAD) * math.cos(ROLL_RAD)),
    )
    return RawSample(accel, GYRO_ZERO_RATE_COUNTS, (300, 200, 300, 200, 0, 0, 0, 0))  # type: ignore[arg-type]
