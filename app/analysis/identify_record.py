"""A recording of the identification routine (docs/FIT.md): one versioned JSON format for the
real robot (`artro link --script identify --record`) and the simulated one (`artro run --script
identify --record`, marked so, with its hidden variation); read back whole or refused with a
sentence saying what is wrong (truncated, foreign, another robot or routine, frames lost)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any, Final, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from app.analysis.identify_replay import Traces
from app.analysis.identify_routine import ROUTINES, routine_id

FORMAT: Final = "artro-identify-recording"
VERSION: Final = 1
Row = Annotated[list[float], Field(min_length=1, max_length=12)]


#: how far a segment recorded on the link may differ from the routine's length: the robot
#: switches at the frame its ACK names, a few frames after the host asked
SLACK_FRAMES = 25
#: frames a recording may lack: the firmware drops a SENSORS its transmit queue cannot take
#: (~30 % while walking at 57600 baud, docs/FIT.md); a fit folds the frames it has onto the
#: gait's cycle, so single frames lost cost it little; a share above this, or a gap longer
#: than LONGEST_GAP frames (the robot silent for half a second), is refused
MAX_LOST_SHARE = 0.5
LONGEST_GAP = 25


class RecordingError(ValueError):
    """A recording that cannot be fitted: the message says why and what is expected."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class SegmentSpan(_Strict):
    name: str
    start: int = Field(ge=0, description="the frame the segment starts at")
    frames: int = Field(ge=1)


class Frames(_Strict):
    """Column by column, one row a frame (units: docs/FIT.md)."""

    frame: list[int] = Field(description="the robot's frame counter: consecutive")
    commanded: list[Row] = Field(description="set-points the servos were sent (12, rad)")
    gyro: list[Row] = Field(description="the IMU's rates (3, rad/s, the IMU's axes)")
    accel: list[Row] = Field(description="the accelerometer (3, m/s^2)")
    fsr: list[Row] = Field(description="foot forces (8, N: left FL FR BL BR, then right)")
    present: list[Row] | None = Field(None, description="bus servos' present positions (12, rad)")
    flags: list[int] = Field(description="the firmware's TELEMETRY flags, 0 in simulation")


class Recording(_Strict):
    """The whole file."""

    format: Literal["artro-identify-recording"]
    version: Literal[1]
    routine: str = Field(description="the routine's name, version and checksum (routine_id)")
    source: Literal["simulation", "robot"]
    robot: str = Field(description="the robot description's name")
    robot_mass_kg: float = Field(gt=0, description="its model's total mass, to tell robots apart")
    params: dict[str, object] = Field(description="the gait set played, every law off")
    truth: str | None = Field(None, description="simulated only: the hidden variation")
    frame_s: Literal[0.02] = 0.02  # type: ignore[valid-type]  # pydantic takes a float const
    segments: list[SegmentSpan]
    first_frame: int = Field(0, ge=0, description="the robot's frame the routine began at")
    frames: Frames
    pose: list[Row] | None = Field(None, description="simulated only: trunk x, y (m), yaw (rad)")


def recording_schema() -> dict[str, object]:
    """The format as a JSON schema (served at GET /api/fit/schema, docs/FIT.md)."""
    return Recording.model_json_schema()


def to_recording(
    traces: Traces,
    *,
    routine: str,
    source: Literal["simulation", "robot"],
    robot: str,
    robot_mass_kg: float,
    params: dict[str, object],
    truth: str | None = None,
    present: bool = False,
    frame_numbers: NDArray[np.int64] | None = None,
    flags: NDArray[np.int64] | None = None,
    lengths: list[int] | None = None,
    first_frame: int = 0,
) -> Recording:
    """`traces` as a recording of `routine`; `lengths` each segment's frames where the robot
    switched (default: the routine's)."""
    steps = ROUTINES[routine]
    lengths = lengths or [s.frames for s in steps]
    n = traces.frames
    frames = Frames(
        frame=(first_frame + traces.positions if frame_numbers is None else frame_numbers).tolist(),
        commanded=traces.commanded.tolist(),
        gyro=traces.gyro.tolist(),
        accel=traces.accel.tolist(),
        fsr=traces.fsr.tolist(),
        present=traces.joints.tolist() if present else None,
        flags=[0] * n if flags is None else flags.tolist(),
    )
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]]).tolist()
    spans = [
        SegmentSpan(name=s.name, start=start, frames=length)
        for s, start, length in zip(steps, starts, lengths, strict=True)
    ]
    return Recording(
        format=FORMAT,
        version=VERSION,
        routine=routine_id(routine),
        source=source,
        robot=robot,
        robot_mass_kg=robot_mass_kg,
        params=params,
        truth=truth,
        segments=spans,
        first_frame=first_frame,
        frames=frames,
        pose=traces.pose.tolist() if source == "simulation" else None,
    )


def write(recording: Recording, path: Path) -> None:
    path.write_text(recording.model_dump_json(), encoding="utf-8")


def read(path: Path) -> Recording:
    """The recording in `path`, checked whole; RecordingError saying what is wrong."""
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise RecordingError(f"cannot read {path}: {exc}") from None
    return parse(text, str(path))


def parse(text: str, where: str = "the recording") -> Recording:
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        cut = " (truncated?)" if exc.pos >= len(text.rstrip()) - 1 else ""
        raise RecordingError(
            f"{where} is not whole JSON{cut}: {exc.msg} at byte {exc.pos}"
        ) from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise RecordingError(
            f"{where} is not an identification recording (its 'format' is not {FORMAT!r}): "
            "record one with `artro link --script identify --record` or `artro run --script "
            "identify --record`"
        )
    if data.get("version") != VERSION:
        raise RecordingError(
            f"{where} is format version {data.get('version')!r}; this artro reads version {VERSION}"
        )
    try:
        recording = Recording.model_validate(data)
    except ValidationError as exc:
        first = exc.errors()[0]
        at = ".".join(str(p) for p in first["loc"])
        raise RecordingError(f"{where}: {at}: {first['msg']}") from None
    check(recording, where)
    return recording


def check(recording: Recording, where: str = "the recording") -> None:
    """The frames whole and of one length, the routine one this artro plays."""
    name = recording.routine.split("-v", 1)[0]
    if name not in ROUTINES or recording.routine != routine_id(name):
        raise RecordingError(
            f"{where} plays the routine {recording.routine!r}; this artro plays "
            f"{', '.join(routine_id(n) for n in ROUTINES)}: record it again"
        )
    f = recording.frames
    routine = ROUTINES[name]
    names = [s.name for s in recording.segments]
    if names != [s.name for s in routine]:
        raise RecordingError(
            f"{where}'s segments are {names}, the routine's {[s.name for s in routine]}"
        )
    start = 0
    for span, segment in zip(recording.segments, routine, strict=True):
        if span.start != start or abs(span.frames - segment.frames) > SLACK_FRAMES:
            raise RecordingError(
                f"{where}: segment {span.name!r} spans frames {span.start}-"
                f"{span.start + span.frames - 1}; it must start at {start} and last "
                f"{segment.frames} ± {SLACK_FRAMES} frames"
            )
        start += span.frames
    n = start
    numbers = np.asarray(f.frame, dtype=np.int64)
    steps = np.diff(numbers)
    if len(numbers) == 0 or (steps <= 0).any():
        raise RecordingError(f"{where}: its frame numbers do not rise: not one robot's recording")
    first = recording.first_frame
    if numbers[0] < first or numbers[-1] >= first + n:
        raise RecordingError(
            f"{where}'s frames run {numbers[0]}-{numbers[-1]}, its routine {first}-{first + n - 1}"
            ": frames out of place"
        )
    lost = n - len(numbers)
    edges = np.concatenate([[numbers[0] - first + 1], steps, [first + n - numbers[-1]]])
    longest = int(edges.max()) - 1
    if lost > MAX_LOST_SHARE * n or longest > LONGEST_GAP:
        gap = np.flatnonzero(steps > 1)
        where_first = (
            f"after frame {numbers[gap[0]]} comes {numbers[gap[0] + 1]}; " if len(gap) else ""
        )
        raise RecordingError(
            f"{where} lost {lost} of {n} frames ({where_first}the longest gap {longest} frames): "
            f"a fit needs at least {1 - MAX_LOST_SHARE:.0%} of them and no gap over "
            f"{LONGEST_GAP}: record it again (a USB adapter at the firmware's rate, nothing "
            "else on the port)"
        )
    n = len(numbers)
    columns: dict[str, list[Any]] = {
        "frame": f.frame,
        "commanded": f.commanded,
        "gyro": f.gyro,
        "accel": f.accel,
        "fsr": f.fsr,
        "flags": f.flags,
    }
    if f.present:
        columns["present"] = f.present
    for column, rows in columns.items():
        if len(rows) != n:
            raise RecordingError(
                f"{where} has {len(rows)} rows of {column!r}, {n} frames: truncated?"
            )
    widths = {"commanded": 12, "gyro": 3, "accel": 3, "fsr": 8, "present": 12}
    for column, width in widths.items():
        got = columns.get(column)
        if got is not None and any(len(r) != width for r in got):
            raise RecordingError(f"{where}: every row of {column!r} has {width} values")


def check_robot(recording: Recording, robot: str, mass_kg: float, where: str = "it") -> None:
    """RecordingError when the recording was made on another robot than the one to fit."""
    if recording.robot != robot or abs(recording.robot_mass_kg - mass_kg) > 1e-6 * mass_kg:
        raise RecordingError(
            f"{where} was recorded on the robot {recording.robot!r} "
            f"({recording.robot_mass_kg:.4g} kg), not {robot!r} ({mass_kg:.4g} kg): fit it "
            f"with --robot {recording.robot}"
        )


def traces_of(recording: Recording) -> Traces:
    """The recorded traces as arrays (the joints: the present positions, else the commands)."""
    f = recording.frames
    n = len(f.frame)
    joints = f.present if f.present is not None else f.commanded
    pose = recording.pose if recording.pose is not None else [[0.0, 0.0, 0.0]] * n
    numbers = np.asarray(f.frame, dtype=np.int64)
    commanded, gyro, accel, fsr, joints_a, pose_a = (
        np.asarray(c, dtype=np.float64) for c in (f.commanded, f.gyro, f.accel, f.fsr, joints, pose)
    )
    return Traces(
        commanded, gyro, accel, fsr, joints_a, pose_a, index=numbers - recording.first_frame
    )
