"""Experiment: where in the gait cycle CA turns the robot.

Backs the "CA steering on this model" section of models/README.md. Walks a preset at a_p with
CA = -p, 0 and +p, frame by frame, and bins every frame by the trunk phase. Per bin it prints
how much the trunk and each foot turned (degrees per gait cycle; + = counter-clockwise) and each
foot's mean normal load (N), then the turn CA added against CA = 0. A foot that turns while it
carries the robot twists on the floor: with the hip yaw servos still, that is the only way the
trunk can turn. The model variants of `ca_response.py` apply here too.

    python bench/ca_phases.py [--preset tuned] [--a-p 0.07] [--ca 0.1] [--duration 40] \
        [--bins 20] [--friction MU] [--sole-grid] [--contact-timeconst S] [--elliptic] \
        [--set GROUP.FIELD=VALUE] [--yaw-per-ca K] [--json PATH]

Writes its figures (per CA: the trunk's turn per cycle and every bin's turns, loads and what CA
adds) to bench/results/<bench>.json, or to --json PATH (bench/results.py).
"""

from __future__ import annotations

import argparse
import math

import mujoco
import numpy as np
import results
from ca_response import add_variant_arguments, describe_variant, load_variant, walking

from app.robots.model import RobotModel
from app.sim.frame_loop import FrameLoop
from app.sim.planning import FRAME_S
from gait import GaitParams, Motion

WARMUP_S = 5.0
FEET = ("l_foot", "r_foot")


def foot_loads_n(model: mujoco.MjModel, data: mujoco.MjData, feet: tuple[int, int]) -> list[float]:
    """Normal contact force on each foot body, N."""
    loads = [0.0, 0.0]
    force = np.zeros(6)
    for i in range(data.ncon):
        contact = data.contact[i]
        bodies = (model.geom_bodyid[contact.geom1], model.geom_bodyid[contact.geom2])
        for k, foot in enumerate(feet):
            if foot in bodies:
                mujoco.mj_contactForce(model, data, i, force)
                loads[k] += float(force[0])
    return loads


def walk(robot: RobotModel, params: GaitParams, motion: Motion, seconds: float) -> np.ndarray:
    """Per frame after the warm-up: phase, trunk yaw, left/right foot yaw, left/right load."""
    sim = FrameLoop(robot, params, motion)
    model, data = sim.model, sim.data
    feet = tuple(model.body(name).id for name in FEET)
    rows = []
    for _ in range(round((WARMUP_S + seconds) / FRAME_S)):
        record = sim.step_frame()
        if sim.fell:
            raise SystemExit(f"the robot fell at CA = {motion.ca:+g} after {sim.time_s:.1f} s")
        if sim.time_s <= WARMUP_S:
            continue
        foot_yaw = [math.atan2(data.xmat[b][3], data.xmat[b][0]) for b in feet]
        loads = foot_loads_n(model, data, feet)
        rows.append([record.phase, sim.trunk_pose()[2], *foot_yaw, *loads])
    return np.asarray(rows)


def per_bin(rows: np.ndarray, bins: int, freq_hz: float) -> np.ndarray:
    """(bins, 5): trunk, left and right foot turn (deg per cycle), left and right load (N)."""
    phase = rows[:-1, 0]
    turns = np.degrees(np.diff(np.unwrap(rows[:, 1:4], axis=0), axis=0))
    which = np.floor((phase + math.pi) / (2.0 * math.pi) * bins).astype(int) % bins
    cycles = len(phase) * FRAME_S * freq_hz
    out = np.zeros((bins, 5))
    for b in range(bins):
        here = which == b
        out[b, :3] = turns[here].sum(axis=0) / cycles
        out[b, 3:] = rows[:-1][here, 4:6].mean(axis=0) if here.any() else np.nan
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    add_variant_arguments(parser)
    parser.add_argument("--ca", type=float, default=0.1, help="p: walks CA = -p, 0, +p")
    parser.add_argument("--duration", type=float, default=40.0)
    parser.add_argument("--bins", type=int, default=20)
    args = results.parse_args(parser)
    params, robot = load_variant(args)
    freq = params.clock.freq_hz
    cas = (0.0, args.ca, -args.ca)
    table = {}
    for ca in cas:
        rows = walk(robot, params, walking(args, ca), args.duration)
        table[ca] = per_bin(rows, args.bins, freq)
    print(
        f"preset {args.preset}, a_p = {args.a_p:+.3f}, {args.duration:g} s after {WARMUP_S:g} s, "
        f"{freq:.3f} Hz; {describe_variant(args)}"
    )
    print("turn in degrees per gait cycle (+ = counter-clockwise), load in N")
    walks = []
    for ca in cas:
        t = table[ca]
        print(f"\nCA = {ca:+g}: trunk {t[:, 0].sum():+.2f} deg per cycle")
        print(" bin  phase   trunk  l_foot  r_foot  l_load  r_load  CA adds (trunk)")
        bins = []
        for b in range(args.bins):
            phase = -math.pi + (b + 0.5) * 2.0 * math.pi / args.bins
            added = t[b, 0] - table[0.0][b, 0] if ca else 0.0
            print(
                f" {b:3d} {phase:+6.2f}  {t[b, 0]:+6.2f}  {t[b, 1]:+6.2f}  {t[b, 2]:+6.2f}  "
                f"{t[b, 3]:6.1f}  {t[b, 4]:6.1f}  {added:+6.2f}"
            )
            bins.append(
                {
                    "bin": b,
                    "phase_rad": phase,
                    "trunk_deg_per_cycle": t[b, 0],
                    "l_foot_deg_per_cycle": t[b, 1],
                    "r_foot_deg_per_cycle": t[b, 2],
                    "l_load_n": t[b, 3],  # null: no frame fell in the bin
                    "r_load_n": t[b, 4],
                    "ca_adds_trunk_deg_per_cycle": added,
                }
            )
        walks.append({"ca": ca, "trunk_deg_per_cycle": t[:, 0].sum(), "bins": bins})
    figures = {
        "variant": describe_variant(args),
        "warmup_s": WARMUP_S,
        "freq_hz": freq,
        "walks": walks,
    }
    headline = {
        f"trunk turn at CA {ca:+g} (deg/cycle)": walk["trunk_deg_per_cycle"]
        for ca, walk in zip(cas, walks, strict=True)
    }
    results.write("ca_phases", args, figures, headline)


if __name__ == "__main__":
    main()
