"""The firmware drive on the Mega board (docs/BOARDS.md): a real server whose simulated servos take
the emulated PCA9685's pulses; its scope frames carry the twelve channels and the frame's I2C
transactions, and its VCD download the channels and a line per part on the bus (read by
sigrok-cli); an ATmega128 frame carries neither."""

from __future__ import annotations

import itertools
import re
import subprocess
from pathlib import Path

import pytest

from app.firmware.mega import STEP_S
from app.firmware.mega_pulses import SLOT_TASKS
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
        replayed = _replayed_vcds(http)
    assert state["drive"] == "firmware" and state["firmware"]["board"] == MEGA
    _check_slots_and_the_pcas_clock(frames)
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
    # a replay of the session: the frames the Mega drove, from what the recorder kept of them
    live_replay, imported, last_frame = replayed
    assert last_frame["recorded"] and last_frame["board"] == MEGA  # drawn as it was live
    assert [c["servo"] for c in last_frame["pca9685"]["channels"]] == list(SERVO_NAMES)
    assert {t["part"] for t in last_frame["i2c"]["transactions"]} == {"PCA9685", "MPU-6050"}
    assert live_replay.status_code == 200
    names = re.findall(r"^\$var wire 1 \S (\S+) \$end$", live_replay.text, re.MULTILINE)
    assert names == [f"PWM{n}" for n in range(12)] + ["I2C_PCA9685", "I2C_MPU6050"]
    assert "the Mega board drove" in live_replay.text
    path.write_text(live_replay.text, encoding="ascii")
    assert len(sigrok_pulses(path, "PWM7")) >= 8
    # an imported file keeps the OCR tables only: refused, saying what there is
    assert imported.status_code == 409, imported.text[:300]
    problem = imported.json()["detail"][0]
    assert problem["type"] == "no_board_lines"
    assert "firmware frames, kept as OCR tables only" in problem["msg"]
    assert problem["msg"].endswith("this download of the live drive"), problem["msg"]
    assert "GET /api/recording/export" in problem["msg"]


def _replayed_vcds(http) -> tuple:
    """The VCD download while the session is replayed, then while a file of it is; the
    replay's last frame."""
    status = http.post("/api/recording/replay", json={})
    assert status.status_code == 200
    last_frame = http.get(f"/api/recording/frame/{status.json()['frames'] - 1}").json()
    live_replay = http.get("/api/recording/export.vcd")
    exported = http.get("/api/recording/export").text
    http.post("/api/recording/live")
    headers = {"content-type": "application/json"}
    assert http.post("/api/recording/import", content=exported, headers=headers).is_success
    imported = http.get("/api/recording/export.vcd")
    http.post("/api/recording/live")
    return live_replay, imported, last_frame


def _check_slots_and_the_pcas_clock(frames: list[dict]) -> None:
    """What the Mega's slots do, as config.h schedules them, and where the PCA9685's period
    began: 11.52 µs earlier each frame (its own oscillator), where its channels rise."""
    config = Path("hardware/firmware/src/config.h").read_text()
    slot = {name: int(v) for name, v in re.findall(r"#define (SENSE_SLOT|COMPUTE_SLOT) (\d+)u",
                                                    config)}  # fmt: skip
    assert SLOT_TASKS == {0: "PCA9685 write", slot["SENSE_SLOT"]: "IMU + FSR read",
                          slot["COMPUTE_SLOT"]: "plan next frame"}  # fmt: skip
    starts = []
    for frame in frames:
        assert frame["slots"] == [{"slot": k, "task": SLOT_TASKS.get(k)} for k in range(8)]
        pca = frame["pca9685"]
        assert pca["period_us"] == pytest.approx(PERIOD_US)
        assert pca["slip_us_per_frame"] == pytest.approx(PERIOD_US - 20_000)
        assert len(pca["period_starts_us"]) <= 2
        for start in pca["period_starts_us"]:
            assert 0 <= start < 20_000
            for c in pca["channels"]:  # ON = 0: every channel rises as its period begins
                assert [start, 1] in c["edges_us"]
        starts.append(pca["period_starts_us"])
    slips = [b[0] - a[-1] for a, b in itertools.pairwise(starts) if a and b]
    assert slips and all(s == pytest.approx(PERIOD_US - 20_000, abs=0.07) for s in slips)


def test_an_atmega128_frame_carries_no_pca9685(server, http) -> None:
    wait_for(lambda: http.get("/api/scope?frames=1").json()["frames"], "scope frames")
    frame = http.get("/api/scope?frames=1").json()["frames"][-1]
    assert not {"board", "pca9685", "i2c"} & frame.keys()
