"""The firmware drive on the Mega board (docs/BOARDS.md): a real server whose simulated servos take
the emulated PCA9685's pulses; its scope frames carry the twelve channels and the frame's I2C
transactions, and its VCD download the channels and a line per part on the bus (read by
sigrok-cli); an ATmega128 frame carries neither."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

from app.firmware.mega import STEP_S
from hardware import SERVO_NAMES
from tests.firmware.test_vcd_sigrok import _ANNOTATION
from tests.testing.server_harness import client, running_server, wait_for

MEGA = "mega2560-pca9685"
PERIOD_US = 4096 * STEP_S * 1e6  # the PCA9685's own period: 19.988 ms


def sigrok_pulses(vcd: Path, line: str) -> list[tuple[float, float]]:
    """sigrok-cli's pwm decoder on one line: (width, period) in µs of each period, from its
    sample numbers at the VCD's 100 ns (its printed period is rounded to 0.1 ms)."""
    out = subprocess.run(
        ["sigrok-cli", "-i", str(vcd), "-P", f"pwm:data={line}", "--protocol-decoder-samplenum"],
        check=True, capture_output=True, text=True, timeout=60,
    ).stdout  # fmt: skip
    pulses = []
    for text in out.splitlines():
        m = _ANNOTATION.match(text)
        assert m, f"unexpected sigrok-cli output: {text!r}"
        if m[3] is not None:  # the duty cycle of the samples from one rise to the next
            period_us = (int(m[2]) - int(m[1])) * 0.1
            pulses.append((float(m[3]) / 100 * period_us, period_us))
    return pulses


def _mega_frames(http, n: int) -> list[dict]:
    frames = http.get(f"/api/scope?frames={n}").json()["frames"]
    return [f for f in frames if f.get("board") == MEGA and f["frame"] >= 3]


@pytest.mark.slow
def test_the_megas_scope_frames_and_vcd_carry_its_channels_and_its_bus(tmp_path: Path) -> None:
    data = tmp_path / "data"
    with running_server(data, drive="firmware", board=MEGA) as (url, _app), client(url) as http:
        frames = wait_for(lambda: len(_mega_frames(http, 40)) >= 10 and _mega_frames(http, 40),
                          "ten scope frames of the Mega board")  # fmt: skip
        state = http.get("/api/state").json()
        vcd = http.get("/api/recording/export.vcd")
    assert state["drive"] == "firmware" and state["firmware"]["board"] == MEGA
    for frame in frames:
        assert frame["source"] == "firmware"
        channels = frame["pca9685"]["channels"]
        assert [c["servo"] for c in channels] == list(SERVO_NAMES)
        assert [c["name"] for c in channels] == [f"PWM{n}" for n in range(12)]
        for c in channels:
            assert 600 <= c["pulse_us"] <= 2400
            assert all(0 <= t < 20_000 and level in (0, 1) for t, level in c["edges_us"])
            # the servo's pulse in the TDM layout is the channel's, to the 0.5 µs tick
            slot = next(s for ch in frame["channels"] for s in ch["slots"]
                        if s["servo"] == c["servo"])  # fmt: skip
            assert abs(slot["pulse_us"] - c["pulse_us"]) <= 0.5
        bus = frame["i2c"]["transactions"]
        write = [t for t in bus if t["part"] == "PCA9685"]
        read = [t for t in bus if t["part"] == "MPU-6050"]
        assert len(write) == 1 and len(read) == 1, bus
        (w,), (r,) = write, read
        assert (w["address"], w["register"], w["bytes"], w["write"]) == (0x40, 0x06, 50, True)
        assert (r["address"], r["register"], r["bytes"], r["restarts"]) == (0x68, 0x3B, 17, 1)
        assert w["acked"] and r["acked"]
        # the write at the frame's start, 1.13 ms at 400 kHz; the IMU burst in slot 3
        assert -100 < w["start_us"] < 100 and w["end_us"] - w["start_us"] == pytest.approx(1130)
        assert 7500 <= r["start_us"] < 10_000 and w["end_us"] < r["start_us"]
        assert r["start_us"] < r["emulated_stop_us"] and r["end_us"] > r["start_us"]
        assert frame["i2c"]["bus_us"] == pytest.approx(1520)
    # the scope's download: the PCA9685's channels and the bus, read by sigrok
    assert vcd.status_code == 200
    text = vcd.text
    names = re.findall(r"^\$var wire 1 \S (\S+) \$end$", text, re.MULTILINE)
    assert names == [f"PWM{n}" for n in range(12)] + ["I2C_PCA9685", "I2C_MPU6050"]
    path = tmp_path / "mega.vcd"
    path.write_text(text, encoding="ascii")
    pulses = sigrok_pulses(path, "PWM3")
    assert len(pulses) >= 8
    for width_us, period_us in pulses:
        assert 600 <= width_us <= 2400
        assert period_us == pytest.approx(PERIOD_US, abs=0.2)  # the part's clock, not 20 ms


def test_an_atmega128_frame_carries_no_pca9685(server, http) -> None:
    wait_for(lambda: http.get("/api/scope?frames=1").json()["frames"], "scope frames")
    frame = http.get("/api/scope?frames=1").json()["frames"][-1]
    assert not {"board", "pca9685", "i2c"} & frame.keys()
