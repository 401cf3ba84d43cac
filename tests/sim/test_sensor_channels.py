"""The sensor channels and the laws declared once (docs/DESIGN.md §15): the trace's columns keep
their names and order, each law's outputs name fields of `feedback.Output`, every drawn channel
has its chart, and the trace's rows are the values the hand-written rows had, to the bit."""

from __future__ import annotations

import dataclasses

import numpy as np

from app.params.schema import GROUP_TITLES
from app.server.recording.sensor_trace import SensorTrace, true_tilt_deg
from app.sim.frame_loop import FrameLoop
from app.sim.sensor_channels import (
    CHANNELS,
    CHARTS,
    COLUMNS,
    ROBOT_CHANNELS,
    ROBOT_OUTPUT_FIELDS,
    ROBOT_SERIES,
    channel_list,
)
from gait import GaitParams, feedback
from gait.feedback import ANKLE_PITCH, HIP_PITCH
from gait.feedback_params import LAWS
from gait.params import LAW_GROUPS, group_class

#: GET /api/sensors's columns as the page and the browser tests know them
KNOWN_COLUMNS = (
    "t_s",
    "pitch_est_deg", "roll_est_deg", "pitch_true_deg", "roll_true_deg",
    "gyro_x_deg_s", "gyro_y_deg_s", "gyro_z_deg_s",
    "tilt_pitch_deg", "tilt_roll_deg", "a_y_delta", "damping_ankle_deg", "damping_hip_deg",
    "cop_pitch_deg", "cop_roll_deg", "timing_freq_hz",
    "cop_l_x_mm", "cop_l_y_mm", "cop_r_x_mm", "cop_r_y_mm", "load_l_n", "load_r_n",
)  # fmt: skip


def test_the_columns_keep_their_names_and_order():
    assert COLUMNS == KNOWN_COLUMNS
    assert len(set(COLUMNS)) == len(COLUMNS)


def test_each_law_is_its_group_in_order_with_outputs_of_the_model():
    assert LAW_GROUPS == ("tilt", "yaw_rate", "damping", "cop", "timing")  # the firmware's bits
    output_fields = {f.name for f in dataclasses.fields(feedback.Output)}
    for law in LAWS:
        assert group_class(law.group) is law.params
        assert GROUP_TITLES[law.group] == law.title
        assert {o.field for o in law.outputs} <= output_fields
    damping = {o.key: o.index for o in LAWS[LAW_GROUPS.index("damping")].outputs}
    assert damping == {"damping_ankle_deg": ANKLE_PITCH[0], "damping_hip_deg": HIP_PITCH[0]}


def test_every_drawn_channel_has_its_chart_and_the_list_says_so():
    assert {c.chart for c in CHANNELS} - {None} == set(CHARTS)
    listed = channel_list()
    assert [c["key"] for c in listed["channels"]] == list(COLUMNS)
    assert [law["group"] for law in listed["laws"]] == list(LAW_GROUPS)


def test_the_robot_carries_what_its_sensors_frame_sends_and_its_series_are_listed_per_chart():
    """The law outputs on the robot follow SENSORS' float32 fields (hardware/firmware/wire.py);
    every robot series is a carried, drawn channel; the list gives each chart its series."""
    assert ROBOT_OUTPUT_FIELDS == ("attitude_rad", "tilt_rad", "a_y_delta", "cop_rad")
    assert ROBOT_CHANNELS[0].key == "t_s"
    not_carried = {c.key for c in CHANNELS} - {c.key for c in ROBOT_CHANNELS}
    assert not_carried == {
        "pitch_true_deg", "roll_true_deg", "damping_ankle_deg", "damping_hip_deg",
        "timing_freq_hz",
    }  # fmt: skip
    listed = channel_list()["robot"]
    assert set(listed) == set(CHARTS)
    assert [s["key"] for chart in listed.values() for s in chart] == [s.key for s in ROBOT_SERIES]
    assert [s["label"] for s in listed["attitude"]] == ["pitch", "roll"]
    assert [s["key"] for s in listed["laws"]] == ["tilt_pitch_deg", "tilt_roll_deg"]


def _hand_written_row(trace: SensorTrace, record, data) -> tuple[float, ...]:
    """The trace's row as it was written by hand before the channels were declared."""
    reading, out = record.reading, record.feedback
    cop = reading.centre_of_pressure_m(trace._positions_m) * 1e3
    gyro = np.degrees(reading.gyro_rad_s)
    attitude, tilt = np.degrees(out.attitude_rad), np.degrees(out.tilt_rad)
    cop_out, damping = np.degrees(out.cop_rad), np.degrees(out.damping_rad)
    return (
        record.time_s + 0.02,
        float(attitude[0]), float(attitude[1]), *true_tilt_deg(data, trace._imu_site),
        float(gyro[0]), float(gyro[1]), float(gyro[2]),
        float(tilt[0]), float(tilt[1]), float(out.a_y_delta),
        float(damping[ANKLE_PITCH[0]]), float(damping[HIP_PITCH[0]]),
        float(cop_out[0]), float(cop_out[1]), float(out.freq_delta_hz),
        float(cop[0, 0]), float(cop[0, 1]), float(cop[1, 0]), float(cop[1, 1]),
        float(reading.fsr_n[0].sum()), float(reading.fsr_n[1].sum()),
    )  # fmt: skip


def test_the_trace_rows_are_the_hand_written_rows_to_the_bit():
    every_law = {g: dataclasses.replace(getattr(GaitParams(), g), enabled=True) for g in LAW_GROUPS}
    loop = FrameLoop(params=dataclasses.replace(GaitParams(), **every_law))
    trace = SensorTrace(loop.robot)
    for _ in range(60):
        record = loop.step_frame()
        trace.add(record, loop.data)
        want = np.array(_hand_written_row(trace, record, loop.data))
        np.testing.assert_array_equal(np.array(trace.view().rows[-1]), want)
    assert np.count_nonzero(np.array(trace.view().rows)[:, 8:16]) > 0  # the laws acted
