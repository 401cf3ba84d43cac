"""The firmware ramps a motion change as the Python frame loop does (`ramp` group): sent over
the emulated UART, the new motion vector and CA reach the gait step by step, or at once with
the ramp off."""

import numpy as np
import pytest

from app.firmware import protocol as proto
from app.firmware.conformance import model_frames
from app.firmware.pulses import FirmwarePulses
from hardware.firmware.schema import values_from_document
from tests.testing.firmware_support import preset


@pytest.mark.parametrize("ramp", [True, False], ids=["ramped", "ramp-off"])
def test_a_motion_change_reaches_the_gait_as_the_model_ramps_it(ramp: bool) -> None:
    old = preset("tuned")
    old["gait"]["ramp"]["enabled"] = ramp
    new = preset("tuned", a_p=0.07, ca=0.1)
    new["gait"]["ramp"]["enabled"] = ramp
    drive = FirmwarePulses(old)
    try:
        frames = [drive.next_frame() for _ in range(3)]
        drive.send_parameters(new)  # on the wire while the frames run, as in the dashboard
        parts = len(proto.set_all_params(values_from_document(new)))  # laws', then the gait's
        acks: list[proto.Ack] = []
        while len(acks) < parts:
            frames.append(drive.next_frame())
            acks += [r for r in frames[-1].replies if isinstance(r, proto.Ack)]
        effective = acks[-1].effective_frame
        assert effective > frames[-1].index  # it reaches a frame still to come
        while drive.frame < effective + 90:  # a_p 0 -> 0.07 at 0.05 rad/s: 70 frames
            frames.append(drive.next_frame())
    finally:
        drive.close()
    model = model_frames(old, len(frames), changes=[(effective, new)])
    angles = np.array([f.angles_rad for f in frames], dtype=np.float64)
    assert np.max(np.abs(angles - model.angles)) < 1e-4
    ocr = np.array([f.ocr for f in frames])
    assert np.max(np.abs(ocr - model.ocr)) <= 1
    # what the ramp changes: right after the change the gait is still near the old motion
    jump = model_frames(
        {**old, "gait": {**old["gait"], "ramp": {**old["gait"]["ramp"], "enabled": False}}},
        len(frames),
        changes=[(effective, {**new, "gait": {**new["gait"], "ramp": {"enabled": False}}})],
    )
    early = slice(effective, effective + 10)
    differs = np.max(np.abs(angles[early] - jump.angles[early])) > 1e-3
    assert differs == ramp
