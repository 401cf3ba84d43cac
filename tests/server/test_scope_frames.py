"""The web oscilloscope's JSON of a frame (app.server.feeds.scope_frames): exact contents."""

from __future__ import annotations

import json

import numpy as np

from app.server.feeds.scope_frames import frame_to_dict
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


def test_a_frame_published_before_a_switch_of_robots_keeps_its_wiring() -> None:
    """The feed formats a frame when it is first asked for; the simulation thread swaps the
    feed's wiring when the robot changes. A frame of the old robot was then named with the
    new robot's channel map; it keeps the one it was published under."""
    from app.server.feeds.scope_feed import ScopeFeed
    from app.sim.frame_loop import FrameLoop
    from hardware import ChannelMap

    record = FrameLoop().step_frame()
    feed = ScopeFeed(CONFIG)
    feed.publish(record, 1)
    swapped = ChannelMap(tuple(reversed(CONFIG.channel_map.assignments)))
    feed.tdm = TdmConfig(channel_map=swapped)  # another robot's wiring, from the next frame
    (frame,) = json.loads(feed.recent_json(1))["frames"]
    first = frame["channels"][0]["slots"][0]
    assert first["servo"] == SERVO_NAMES[0]  # as wired when it was published
