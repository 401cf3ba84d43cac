"""`artro link --script identify --record REC.json` (docs/FIT.md): the identification routine
played by the robot's firmware on the link, segment by segment (each segment's changed values
in SET_PARAMS, its start the frame the ACK names), every frame's SENSORS recorded, the commands
the gait made of it added from the model (the firmware's pulses are the model's, pin-exact)."""

from __future__ import annotations

import dataclasses
import threading
from collections.abc import Callable

import numpy as np

from app.analysis import identify_record
from app.analysis.identify_record import Recording
from app.analysis.identify_replay import Traces, play
from app.analysis.identify_routine import ROUTINES, open_loop, segment_params
from app.firmware import protocol as proto
from app.firmware.robot_link import LinkError, RobotLink
from app.firmware.sensor_feed import RawSample, decoded
from app.params.document import ParameterSet
from app.robots.model import RobotModel
from hardware.firmware.schema import values_from_document

#: a segment's values are sent this many frames before it is due (a SET_PARAMS and its ACK
#: take ~3 frames at 57600 baud)
LEAD_FRAMES = 4
#: frames the robot may go without a SENSORS before the routine stops as lost (1 s)
SILENT_FRAMES = 50


class FrameClock:
    """The newest frame the robot's stream told, and every SENSORS by frame; `wait_for` returns
    when a frame is reached (or `stop`, or the stream stayed silent)."""

    def __init__(self) -> None:
        self.frames: dict[int, proto.Sensors] = {}
        self.newest = -1
        self._seen = threading.Condition()

    def put(self, sensors: proto.Sensors) -> None:
        with self._seen:
            self.frames[sensors.frame] = sensors
            self.newest = max(self.newest, sensors.frame)
            self._seen.notify_all()

    def wait_for(self, frame: int, stop: threading.Event) -> None:
        """Until the stream reaches `frame`; LinkError when it stays silent SILENT_FRAMES."""
        with self._seen:
            while self.newest < frame and not stop.is_set():
                before = self.newest
                self._seen.wait(SILENT_FRAMES * 0.02)
                if self.newest == before:
                    raise LinkError(f"the robot's sensor stream stopped at frame {before}")


def _ack_frame(reply: proto.Reply | None) -> int:
    if not isinstance(reply, proto.Ack):
        raise LinkError(
            "the robot did not acknowledge the routine's step (a dry run records nothing)"
        )
    return reply.effective_frame


def record_identify(
    link: RobotLink,
    robot: RobotModel,
    pset: ParameterSet,
    stop: threading.Event,
    log: Callable[[str], None] = print,
) -> Recording:
    """Play the identify routine on the robot behind `link` with `pset`'s gait, every law off;
    the recording of what it did. The caller switches the servos off after (also on error)."""
    routine = ROUTINES["identify"]
    gait = open_loop(pset.gait)
    docs = [
        dataclasses.replace(pset, gait=segment_params(gait, s), motion=s.motion).to_dict()
        for s in routine
    ]
    clock = FrameClock()
    link.send_set(docs[0])
    link.stream_sensors(clock.put)
    starts = [_ack_frame(link.expect(proto.command(proto.Msg.START), "start"))]
    log(
        f"identify: {len(routine)} segments, ~{sum(s.frames for s in routine) * 0.02:.0f} s, "
        f"from frame {starts[0]} (Ctrl-C stops and switches the servos off)"
    )
    planned = starts[0]
    for i, segment in enumerate(routine[1:], 1):
        planned += routine[i - 1].frames
        clock.wait_for(planned - LEAD_FRAMES, stop)
        if stop.is_set():
            raise KeyboardInterrupt
        starts.append(_send_changes(link, docs[i - 1], docs[i]))
        log(f"identify: {segment.name} from frame {starts[-1]}")
    end = starts[-1] + routine[-1].frames
    clock.wait_for(end, stop)
    if stop.is_set():
        raise KeyboardInterrupt
    link.end_stream()
    lengths = [b - a for a, b in zip(starts, [*starts[1:], end], strict=True)]
    return _recording(clock, robot, gait, starts[0], lengths)


def _send_changes(link: RobotLink, before: dict, after: dict) -> int:
    """The SET_PARAMS of the values that differ between two sets; the frame the last one's ACK
    names (all are in force from there)."""
    old, new = values_from_document(before), values_from_document(after)
    messages = [
        m
        for m, o in zip(proto.set_all_params(new), proto.set_all_params(old), strict=True)
        if m != o
    ]
    frame = None
    for message in messages or proto.set_all_params(new)[-1:]:
        frame = _ack_frame(link.expect(message, "the routine's next segment"))
    assert frame is not None
    return frame


def _recording(
    clock: FrameClock, robot: RobotModel, gait, first: int, lengths: list[int]
) -> Recording:
    """The frames from `first` on as a recording: each SENSORS tagged with the frame its
    reading corrected, i.e. the reading after the frame before it (PROTOCOL.md). A SENSORS the
    firmware dropped (its transmit queue full) is a frame the recording lacks."""
    n = sum(lengths)
    numbers = [f for f in range(first, first + n) if f + 1 in clock.frames]
    rows = [clock.frames[f + 1] for f in numbers]
    readings = [decoded(RawSample(s.accel_raw, s.gyro_raw, s.adc), s.gyro_offset) for s in rows]
    model = play(robot, gait, ROUTINES["identify"], lengths=lengths)  # the commands, pin-exact
    kept = np.asarray(numbers, dtype=np.int64) - first
    traces = Traces(
        commanded=model.commanded[kept],
        gyro=np.array([r.gyro_rad_s for r in readings]).reshape(-1, 3),
        accel=np.array([r.accel_m_s2 for r in readings]).reshape(-1, 3),
        fsr=np.array([np.ravel(r.fsr_n) for r in readings]).reshape(-1, 8),
        joints=model.commanded[kept],
        pose=np.zeros((len(kept), 3)),
        index=kept,
    )
    return identify_record.to_recording(
        traces,
        routine="identify",
        source="robot",
        robot=robot.name,
        robot_mass_kg=robot.total_mass_kg(),
        params=gait.to_dict(),
        frame_numbers=np.asarray(numbers, dtype=np.int64),
        flags=np.array([s.status for s in rows], dtype=np.int64),
        lengths=lengths,
        first_frame=first,
    )
