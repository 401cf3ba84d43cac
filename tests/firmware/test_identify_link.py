"""`artro link --script identify --record` against the emulated firmware on its pty, paced to
wall time as the robot runs (docs/FIT.md): the routine is played segment by segment at the
frames the robot's ACKs name, its SENSORS recorded, and the file reads back as a recording of
the robot."""

from __future__ import annotations

import numpy as np
import pytest

from app.analysis import identify_record as rec
from app.analysis.identify_routine import IDENTIFY
from app.cli import main
from app.firmware.sensor_feed import sample_of
from tests.testing.firmware_support import emulator, preset, served_on_a_pty, tilted

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    out = tmp_path_factory.mktemp("link") / "rec.json"
    with (
        emulator(preset("paper"), sensors=sample_of(tilted())) as mcu,
        served_on_a_pty(mcu, realtime=True) as port,  # the host paced as on the robot
    ):
        status = main(["link", "--port", port, "--script", "identify", "--record", str(out),
                       "--params", "robust"])  # fmt: skip
    return status, out


def test_the_routine_is_recorded_whole(recorded):
    status, out = recorded
    assert status == 0
    recording = rec.read(out)  # checked whole: no frame lost, segments in place
    assert recording.source == "robot" and recording.truth is None
    lengths = [s.frames for s in recording.segments]
    assert [s.name for s in recording.segments] == [s.name for s in IDENTIFY]
    assert all(
        abs(n - s.frames) <= rec.SLACK_FRAMES for n, s in zip(lengths, IDENTIFY, strict=True)
    )
    assert recording.params["tilt"]["enabled"] is False  # every law off


def test_the_sensors_are_the_robots(recorded):
    """The emulated IMU reads `tilted()`: the recording's accelerometer is that lean, in SI."""
    recording = rec.read(recorded[1])
    accel = np.asarray(recording.frames.accel)
    pitch = np.arctan2(-accel[:, 0], accel[:, 2])
    assert np.allclose(pitch, 0.12, atol=0.01)
    assert np.allclose(np.linalg.norm(accel, axis=1), 9.81, atol=0.1)
    fsr = np.asarray(recording.frames.fsr)
    assert fsr[:, :4].sum() > 0 and fsr[:, 4:].sum() == 0  # the left foot's ADC only
