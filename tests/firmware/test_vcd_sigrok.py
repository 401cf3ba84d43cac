"""The VCD export read by a real logic-analyser tool (docs/DESIGN.md §5): Debian's `sigrok-cli`
(installed by `scripts/setup.sh --test`) and its `pwm` decoder give each servo the pulse widths
of the model, and each slot its 2.5 ms period, from the file as written."""

from __future__ import annotations

import itertools
import re
import subprocess
from pathlib import Path

import numpy as np

from app.firmware.conformance import check_firmware, model_frames
from app.firmware.vcd import edges_of_frames, write_vcd
from app.robots.model import RobotModel
from hardware import (
    CHANNELS,
    SLOT_TICKS,
    SLOTS_PER_FRAME,
    TICK_US,
    HardwareSetup,
    frame_edges,
    frame_ocr,
    ocr_to_pulse_us,
)
from tests.testing.firmware_support import preset

_ANNOTATION = re.compile(r"^(\d+)-(\d+) pwm-1: (?:([\d.]+)%|([\d.]+) (ms|μs))$")
_TO_US = {"ms": 1000.0, "μs": 1.0}


def decoded_pulses(vcd: Path, line: str) -> dict[float, tuple[float, float]]:
    """sigrok-cli's pwm decoder on one line: per period (rising edge to rising edge) its start
    and its pulse width and period, in µs, as sigrok's own time base gives them."""
    out = subprocess.run(
        ["sigrok-cli", "-i", str(vcd), "-P", f"pwm:data={line}", "--protocol-decoder-samplenum"],
        check=True, capture_output=True, text=True, timeout=60,
    ).stdout  # fmt: skip
    duty: dict[tuple[int, int], float] = {}
    period: dict[tuple[int, int], float] = {}
    for text in out.splitlines():
        m = _ANNOTATION.match(text)
        assert m, f"unexpected sigrok-cli output: {text!r}"
        span = (int(m[1]), int(m[2]))
        if m[3] is not None:
            duty[span] = float(m[3]) / 100
        else:
            period[span] = float(m[4]) * _TO_US[m[5]]
    assert duty.keys() == period.keys()
    pulses = {}
    for (ss, es), p_us in period.items():
        us_per_sample = p_us / (es - ss)
        pulses[ss * us_per_sample] = (duty[ss, es] * p_us, p_us)
    return pulses


def assert_each_servo_decoded(vcd: Path, ocr: np.ndarray, hardware: HardwareSetup) -> None:
    """Every pulse sigrok can measure (a rising edge at its start and one after it: all but
    frame 0's slot 0 and each line's last) is the model's (OCR + 1) ticks wide on its servo's
    (channel, slot); consecutive slots are 2.5 ms apart."""
    slot_us = SLOT_TICKS * TICK_US
    channel_map = hardware.tdm.channel_map
    checked = 0
    for channel, line in enumerate(CHANNELS):
        pulses = decoded_pulses(vcd, line)
        starts = [
            (frame * SLOTS_PER_FRAME + slot) * slot_us
            for frame in range(len(ocr))
            for slot in range(SLOTS_PER_FRAME)
            if ocr[frame, channel, slot] >= 0
        ]
        measurable = [s for s in starts[:-1] if s > 0]
        assert sorted(pulses) == measurable, line
        for start, after in itertools.pairwise(starts):
            if start == 0:
                continue
            frame, slot = divmod(round(start / slot_us), SLOTS_PER_FRAME)
            servo = channel_map.servo_at(channel, slot)
            assert servo is not None
            width_us, period_us = pulses[start]
            expected = ocr_to_pulse_us(ocr[frame, channel, slot])
            assert abs(width_us - expected) < 0.01, (line, frame, slot, width_us, expected)
            assert period_us == after - start
            checked += 1
    assert checked > 0


def test_sigrok_decodes_the_dashboards_export_to_the_pulses_of_its_ocr_tables(tmp_path):
    """The dashboard's export.vcd: the recorded OCR tables put on the wires by the model."""
    hardware = HardwareSetup()
    rng = np.random.default_rng(33)
    pulse_us = rng.uniform(600.0, 2400.0, size=(4, 12))
    ocr = np.stack([frame_ocr(p, hardware.tdm) for p in pulse_us])
    edges = edges_of_frames([frame_edges(o, hardware.tdm) for o in ocr])
    vcd = tmp_path / "export.vcd"
    write_vcd(vcd, edges, 0)
    assert "$timescale 100ns $end" in vcd.read_text()
    assert_each_servo_decoded(vcd, ocr, hardware)
    one = decoded_pulses(vcd, "OC1A")
    assert [p for _, p in sorted(one.values())][:3] == [2500.0] * 3  # a slot is 2.5 ms


def test_sigrok_decodes_the_emulated_firmwares_vcd_to_the_models_pulses(tmp_path):
    """`artro firmware run --vcd`: the emulated MCU's pins, each servo's widths the model's."""
    doc = preset("tuned", a_p=0.07)
    robot = RobotModel.load()
    vcd = tmp_path / "walk.vcd"
    summary = check_firmware(doc, 4, str(vcd), robot)
    assert summary["exact"] == summary["pulses_compared"] == 48
    model = model_frames(doc, 4, robot.hardware(), geometry=robot.geometry)
    assert_each_servo_decoded(vcd, np.asarray(model.ocr), robot.hardware())
