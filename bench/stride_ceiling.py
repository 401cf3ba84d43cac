"""Experiment: how fast the gait's own kinematics let a preset walk forward, against what it walks
(decision 0070).

The leg swings by a_p theta_Swing (eq (28)), so each foot's commanded stroke under the hip is
about 2 a_p times the leg, and with two steps a cycle the trunk can advance at most
2 f x stroke (the ceiling). Walks the preset on the nominal model at a_p = +-A_P for each clock
frequency and measures, after the warm-up: the commanded stroke (the set-points through forward
kinematics at the trunk's pose: the trunk's x less the sole's, peak to peak a gait cycle, median
of the cycles, mean of the feet), the ceiling, the speed walked, its share of the ceiling, and
the support sole's slip (how fast the loaded sole moves on the floor).

    python bench/stride_ceiling.py [--preset robust] [--freqs 0.6,0.7,0.8,0.9,1.0]
        [--duration 30] [--json PATH]

Writes bench/results/stride_ceiling.json (bench/results.py).
"""

from __future__ import annotations

import argparse
import dataclasses

import mujoco
import numpy as np
import results
from ca_phases import foot_loads_n

from app.robots.model import RobotModel
from app.sim.frame_loop import FrameLoop
from app.sim.planning import FRAME_S
from app.study.walks import resolve_presets
from gait import GaitParams, Motion
from gait.params import replace_checked

WARMUP_S = 5.0
A_P = 0.07  # the paper's forward walk


def walk(robot: RobotModel, params: GaitParams, a_p: float, duration_s: float) -> dict:
    """One nominal walk's speed, commanded stroke, ceiling and slip."""
    loop = FrameLoop(robot, params, Motion(a_p=a_p))
    model, data = loop.model, loop.data
    commanded = mujoco.MjData(model)
    soles = [model.site("l_sole").id, model.site("r_sole").id]
    rows, slip, start = [], 0.0, None
    previous_sole = None
    for _ in range(round(duration_s / FRAME_S)):
        record = loop.step_frame()
        if loop.fell:
            return {"a_p": a_p, "fell_at_s": round(loop.time_s, 2)}
        if loop.time_s < WARMUP_S:
            continue
        commanded.qpos[:] = data.qpos
        commanded.qpos[robot.qpos_adr] = record.setpoint
        mujoco.mj_kinematics(model, commanded)
        trunk_x = float(data.qpos[0])
        sole_x = np.array([data.site_xpos[s][0] for s in soles])
        support = int(np.argmax(foot_loads_n(model, data, robot.foot_ids)))
        if previous_sole is not None:
            slip += sole_x[support] - previous_sole[support]
        previous_sole = sole_x
        start = start or (loop.time_s, trunk_x)
        rows.append((loop.time_s, *(trunk_x - commanded.site_xpos[s][0] for s in soles)))
    t0, x0 = start  # type: ignore[misc]
    elapsed = loop.time_s - t0
    table = np.array(rows)
    freq = params.clock.freq_hz
    cycle = ((table[:, 0] - t0) * freq).astype(int)
    whole = range(int(cycle.max()))  # the last cycle is cut short
    stroke = float(np.mean([
        np.median([np.ptp(table[cycle == c, k]) for c in whole]) for k in (1, 2)
    ]))  # fmt: skip
    speed = (float(data.qpos[0]) - x0) / elapsed
    ceiling = 2 * freq * stroke
    return {
        "a_p": a_p,
        "speed_cm_s": round(100 * speed, 3),
        "stroke_cm": round(100 * stroke, 3),
        "ceiling_cm_s": round(100 * ceiling, 3),
        "of_ceiling": round(abs(speed) / ceiling, 3),
        "slip_cm_s": round(100 * slip / elapsed, 3),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="robust", help="preset name or file (default robust)")
    parser.add_argument("--freqs", default="0.6,0.7,0.8,0.9,1.0",
                        help="clock frequencies, Hz (default 0.6,0.7,0.8,0.9,1.0)")  # fmt: skip
    parser.add_argument("--duration", type=float, default=30.0, help="seconds a walk (default 30)")
    args = results.parse_args(parser)
    (preset,), _notes = resolve_presets([args.preset])
    robot = RobotModel.load()
    rows = []
    for freq in (float(f) for f in args.freqs.split(",")):
        clock = replace_checked(preset.params.clock, {"freq_hz": freq}, "clock")
        params = dataclasses.replace(preset.params, clock=clock)
        for a_p in (A_P, -A_P):
            row = {"freq_hz": freq, **walk(robot, params, a_p, args.duration)}
            rows.append(row)
            print(" ".join(f"{k} {v}" for k, v in row.items()), flush=True)
    own = [r for r in rows if r["freq_hz"] == preset.params.clock.freq_hz and r["a_p"] > 0]
    headline = {}
    if own and "ceiling_cm_s" in own[0]:
        headline = {
            "forward ceiling at the preset's clock (cm/s; the paper 3.8)": own[0]["ceiling_cm_s"],
            "forward speed of the ceiling at the preset's clock": own[0]["of_ceiling"],
        }
    results.write("stride_ceiling", args, {"preset": preset.name, "walks": rows}, headline)


if __name__ == "__main__":
    main()
