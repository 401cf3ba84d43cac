"""A preset loaded mid-walk reaches the servos over two seconds, as a change of motion is ramped
(issue 18, item 4): in the real server's recording, no frame's pulses jump further than walking
moves them, where the new constants at once made them jump up to 3.5 times as far."""

from __future__ import annotations

import numpy as np
import pytest

from app.params.presets import builtin_presets
from app.server.sim.gait_ramp import GAIT_RAMP_S, blend
from tests.testing.server_harness import client, running_server, wait_for

FRAME_S = 0.02
RAMP_FRAMES = round(GAIT_RAMP_S / FRAME_S)
STEADY_FRAMES = 200  # walking before and after: the largest step of every pulse in 4 s


def _sim_time(http) -> float:
    return http.get("/api/state").json()["sim_time_s"]


def _walk(http, seconds: float) -> None:
    until = _sim_time(http) + seconds
    wait_for(lambda: _sim_time(http) >= until, f"{seconds} s more walking", attempts=2000)


def largest_step(ocr: np.ndarray) -> int:
    """The largest change of any pulse (OCR ticks of 0.5 us) from one frame to the next."""
    return int(np.abs(np.diff(ocr.astype(np.int64), axis=0)).max())


@pytest.mark.slow
def test_presets_loaded_mid_walk_never_jerk_the_servos(tmp_path):
    with running_server(tmp_path) as (base_url, app), client(base_url) as http:
        http.post("/api/presets/tuned/load")
        http.patch("/api/params", json={"motion": {"a_p": 0.05, "ca": 0.1}})  # as in the issue
        http.put("/api/sim/speed", json={"speed": 2.0})
        http.post("/api/sim/reset")
        _walk(http, 6.0)
        loads = []
        for name in ("paper", "tuned", "paper"):
            loaded = http.post(f"/api/presets/{name}/load", params={"keep_motion": "true"})
            assert loaded.status_code == 200 and loaded.json()["motion"]["a_p"] == 0.05
            loads.append(loaded.json()["version"])
            _walk(http, (RAMP_FRAMES + STEADY_FRAMES + 20) * FRAME_S)
        state = http.get("/api/state").json()
        assert not state["fell"] and state["resets"] == 1
        rec = app.state.services.sim.recorder.recording()
    for version in loads:
        k = int(np.argmax(rec.version >= version))  # the first frame made after the load
        assert rec.version[k] == version
        before = largest_step(rec.ocr[k - STEADY_FRAMES : k])
        ramp = largest_step(rec.ocr[k - 1 : k + RAMP_FRAMES + 10])
        after = largest_step(rec.ocr[k + RAMP_FRAMES + 10 : k + RAMP_FRAMES + STEADY_FRAMES])
        assert ramp <= 1.1 * max(before, after), (
            f"version {version}: a pulse jumped {ramp} ticks in one frame while loading; "
            f"walking moves them at most {before} before and {after} after"
        )


def test_the_blend_goes_from_one_set_to_the_other():
    presets = builtin_presets()
    tuned, paper = presets["tuned"].gait, presets["paper"].gait
    assert blend(tuned, paper, 0.0) == tuned and blend(tuned, paper, 1.0) == paper
    half = blend(tuned, paper, 0.5)
    assert half.clock.freq_hz == pytest.approx((tuned.clock.freq_hz + paper.clock.freq_hz) / 2)
    assert half.leg.paper_signs == paper.leg.paper_signs  # switches go halfway
    assert blend(tuned, paper, 0.4).leg.paper_signs == tuned.leg.paper_signs
