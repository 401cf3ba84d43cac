"""Experiment: the expected roll swing the step-timing law compares against (decision 0061).

Walks a preset open loop on the nominal model with the sensors watched (the attitude estimate
as the laws see it) at a_r = 0 and +-A_R, and fits roll = offset + swing cos(phi_Trunk + phase)
to each walk's frames after the warm-up (`gait.timing.fit_roll_swing`): the `timing` group's
swing_rad, swing_phase_rad, roll_offset_rad; roll_per_a_r and swing_per_a_r from the side
steps.

    python bench/timing_reference.py [--preset robust] [--duration 12] [--json PATH]

Writes the fits and the fields to set to bench/results/timing_reference.json (bench/results.py).
"""

from __future__ import annotations

import argparse

import numpy as np
import results

from app.robots.model import RobotModel
from app.sim.frame_loop import FrameLoop
from app.study.walks import resolve_presets
from gait import Motion
from gait.timing import fit_roll_swing

WARMUP_S = 4.0
A_R = 0.1


def walk_roll(loop: FrameLoop, frames: int) -> tuple[np.ndarray, np.ndarray]:
    """(phi_Trunk, the estimated roll after it) of each frame walked past the warm-up."""
    phases, rolls = [], []
    for k in range(frames):
        record = loop.step_frame()
        if loop.fell:
            raise SystemExit(f"the nominal walk fell at {record.time_s:.1f} s: no reference")
        if k * 0.02 >= WARMUP_S and record.feedback is not None:
            phases.append(record.phase)
            rolls.append(float(record.feedback.attitude_rad[1]))
    return np.array(phases), np.array(rolls)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="robust", help="preset name or file (default robust)")
    parser.add_argument("--duration", type=float, default=12.0, help="seconds a walk (default 12)")
    args = results.parse_args(parser)
    (preset,), _notes = resolve_presets([args.preset])
    robot = RobotModel.load()
    fits = {}
    for a_r in (0.0, A_R, -A_R):
        loop = FrameLoop(robot, preset.params, Motion(a_r=a_r))
        loop.watch_sensors = True
        loop.reset()
        phase, roll = walk_roll(loop, round(args.duration / 0.02))
        offset, swing, swing_phase = fit_roll_swing(phase, roll)
        rms = float(np.sqrt(np.mean((roll - offset - swing * np.cos(phase + swing_phase)) ** 2)))
        fits[f"a_r={a_r:+.2f}"] = {
            "roll_offset_rad": offset, "swing_rad": swing, "swing_phase_rad": swing_phase,
            "residual_rms_rad": rms,
        }  # fmt: skip
        print(f"a_r {a_r:+.2f}: offset {offset:+.4f} rad, swing {swing:.4f} rad at "
              f"{swing_phase:+.3f} rad, residual {rms:.4f} rad rms")  # fmt: skip
    still = fits["a_r=+0.00"]
    per_a_r = (
        fits[f"a_r={A_R:+.2f}"]["roll_offset_rad"] - fits[f"a_r={-A_R:+.2f}"]["roll_offset_rad"]
    )
    side = (fits[f"a_r={A_R:+.2f}"]["swing_rad"] + fits[f"a_r={-A_R:+.2f}"]["swing_rad"]) / 2
    fields = {
        "timing.roll_offset_rad": round(still["roll_offset_rad"], 3),
        "timing.swing_rad": round(still["swing_rad"], 3),
        "timing.swing_phase_rad": round(still["swing_phase_rad"], 2),
        "timing.roll_per_a_r": round(per_a_r / (2 * A_R), 2),
        "timing.swing_per_a_r": round((side - still["swing_rad"]) / A_R, 2),
    }
    print("set:", " ".join(f"{k}={v}" for k, v in fields.items()))
    results.write("timing_reference", args, {"fits": fits, "fields": fields}, fields)


if __name__ == "__main__":
    main()
