"""The web oscilloscope's JSON of a frame (app.server.scope_frames): exact contents."""

from __future__ import annotations

import json

import numpy as np

from app.server.scope_frames import frame_to_dict
from hardware import SERVO_NAMES, TdmConfig, frame_ocr

CONFIG = TdmConfig()
R_KNEE = 9


def centred_frame() -> np.ndarray:
    return frame_ocr(np.full(12, 1500.0), CONFIG)


def test_frame_to_dict_is_json_ready() -> None:
    ocr = centred_frame()
    ocr[0, 0] = 4950
    saturated = np.zeros(12, dtype=bool)
    saturated[R_KNEE] = True
    data = json.loads(json.dumps(frame_to_dict(ocr, CONFIG, saturated=saturated)))
    assert data["select_change_ticks"] == 4900
    assert [c["name"] for c in data["channels"]] == ["OC1A", "OC1B", "OC1C", "OC3A", "OC3B", "OC3C"]
    oc1a = data["channels"][0]["slots"]
    assert [s["servo"] for s in oc1a] == list(SERVO_NAMES[:5])
    assert oc1a[0] | {"guard_violation": True} == {
        "slot": 0,
        "servo": "l_hip_yaw",
        "ocr_ticks": 4950,
        "pulse_us": 2475.5,
        "fall_tick": 4900,
        "decoded_us": 2450.0,
        "guard_violation": True,
        "glitch": False,
        "saturated": False,
    }
    assert oc1a[1]["glitch"] and oc1a[1]["decoded_us"] == 25.5
    assert data["channels"][1]["slots"][3]["saturated"]
    assert data["channels"][4]["slots"] == []
    assert data["flags"] == {
        "guard_violation": True,
        "glitch": ["l_hip_roll"],
        "saturated": ["r_knee"],
        "stray": [],
    }
    assert data["lines"][8] == {"name": "S2", "initial": 0, "edges": [[19900, 1], [39900, 0]]}
