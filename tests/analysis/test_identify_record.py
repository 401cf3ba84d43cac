"""The identification routine's recording (docs/FIT.md): written and read back to the value, and
every way a file can be unfit refused with a sentence saying why (truncated, foreign, another
version, routine or robot, frames lost, a segment out of place)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from app.analysis import identify_record as rec
from app.analysis.identify_replay import play
from app.analysis.identify_routine import IDENTIFY, ROUTINES, open_loop, routine_id, total_frames
from app.robots.gait_reach import preset_gait
from app.robots.model import RobotModel
from app.worlds.variations import parse_variation

TRUTH = "latency_ms=20,kp_scale=0.9,gyro_bias_deg_s=0.2,gyro_noise_deg_s=0.1"


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    robot = RobotModel.load()
    gait = open_loop(preset_gait(robot.description.default_preset))
    traces = play(robot, gait, IDENTIFY, parse_variation(TRUTH))
    recording = rec.to_recording(
        traces, routine="identify", source="simulation", robot=robot.name,
        robot_mass_kg=robot.total_mass_kg(), params=gait.to_dict(), truth=TRUTH,
    )  # fmt: skip
    path = tmp_path_factory.mktemp("rec") / "rec.json"
    rec.write(recording, path)
    return path, traces, robot


def test_a_recording_reads_back_to_the_value(recorded):
    path, traces, _ = recorded
    back = rec.read(path)
    again = rec.traces_of(back)
    assert back.source == "simulation" and back.truth == TRUTH
    assert back.routine == routine_id("identify")
    assert len(back.frames.frame) == total_frames(IDENTIFY) == traces.frames
    np.testing.assert_array_equal(again.gyro, traces.gyro)
    np.testing.assert_array_equal(again.fsr, traces.fsr)
    np.testing.assert_array_equal(again.commanded, traces.commanded)


def test_the_routine_stands_and_moves(recorded):
    """The routine is played through on the default robot with a plausible variation, and its
    walks move the trunk the ways they say (forward, sideways, turning)."""
    _, traces, _ = recorded
    assert traces.fell_frame is None
    starts = np.cumsum([0] + [s.frames for s in IDENTIFY])
    spans = zip(IDENTIFY, starts[:-1], starts[1:], strict=True)
    moved = {s.name: traces.pose[b - 1] - traces.pose[a] for s, a, b in spans}
    assert moved["forward"][0] > 0.05
    assert moved["right"][1] < -0.05 and moved["left"][1] > 0.05
    assert moved["turn clockwise"][2] < -0.2 and moved["turn anticlockwise"][2] > 0.2


def _text(path):
    return path.read_text(encoding="utf-8")


def test_a_truncated_file_is_refused(recorded):
    text = _text(recorded[0])
    with pytest.raises(rec.RecordingError, match="not whole JSON"):
        rec.parse(text[: len(text) // 2])


def test_a_foreign_file_is_refused(recorded):
    with pytest.raises(rec.RecordingError, match="not an identification recording"):
        rec.parse(json.dumps({"frames": []}))


def test_another_version_is_refused(recorded):
    data = json.loads(_text(recorded[0]))
    data["version"] = 2
    with pytest.raises(rec.RecordingError, match="version 2; this artro reads version 1"):
        rec.parse(json.dumps(data))


def test_another_routine_is_refused(recorded):
    data = json.loads(_text(recorded[0]))
    data["routine"] = "identify-v0-00000000"
    with pytest.raises(rec.RecordingError, match="plays the routine 'identify-v0-00000000'"):
        rec.parse(json.dumps(data))


def _without(data, rows):
    for column in ("frame", "commanded", "gyro", "accel", "fsr", "flags"):
        data["frames"][column] = [v for i, v in enumerate(data["frames"][column]) if i not in rows]
    return data


def test_single_lost_frames_are_kept_as_gaps(recorded):
    """The firmware drops a SENSORS it cannot send (docs/FIT.md): a third of the frames lost one
    at a time reads back, each row at its frame in the routine."""
    data = _without(json.loads(_text(recorded[0])), set(range(1, 3000, 3)))
    traces = rec.traces_of(rec.parse(json.dumps(data)))
    assert traces.frames == 2000
    np.testing.assert_array_equal(traces.positions[:4], [0, 2, 3, 5])
    np.testing.assert_array_equal(traces.gyro[1], recorded[1].gyro[2])


def test_too_many_lost_frames_are_named(recorded):
    data = _without(json.loads(_text(recorded[0])), set(range(1000, 1030)))
    with pytest.raises(
        rec.RecordingError, match=r"lost 30 of 3000 frames \(after frame 999 comes 1030"
    ):
        rec.parse(json.dumps(data))
    data = _without(json.loads(_text(recorded[0])), set(range(0, 3000, 3)) | set(range(1, 3000, 3)))
    with pytest.raises(rec.RecordingError, match="lost 2000 of 3000 frames"):
        rec.parse(json.dumps(data))


def test_a_short_column_is_refused(recorded):
    data = json.loads(_text(recorded[0]))
    data["frames"]["gyro"].pop()
    with pytest.raises(rec.RecordingError, match="2999 rows of 'gyro', 3000 frames"):
        rec.parse(json.dumps(data))


def test_a_segment_out_of_place_is_refused(recorded):
    data = json.loads(_text(recorded[0]))
    data["segments"][1]["start"] += 5
    with pytest.raises(rec.RecordingError, match="segment 'weight shifts' spans"):
        rec.parse(json.dumps(data))


def test_another_robot_is_refused(recorded):
    recording = rec.read(recorded[0])
    with pytest.raises(rec.RecordingError, match="recorded on the robot 'artro'"):
        rec.check_robot(recording, "micro", 0.9)


def test_the_schema_describes_the_format():
    schema = rec.recording_schema()
    assert schema["properties"]["format"]["const"] == rec.FORMAT
    assert {"frames", "segments", "routine", "robot"} <= set(schema["required"])
    assert set(ROUTINES) == {"identify"}
