"""Experiment: how the heading rate answers CA, on the built-in model or a variant of it.

Backs the "CA steering on this model" section of models/README.md. Walks a preset at a_p with CA
over a sweep (batch rollouts) and prints, per CA, the measured heading rate next to eq (13)'s,
then the gain and bend of the CA = +-0.1 pair (`app.analysis.cases.Steering`). Variants of the
model, for the experiment only (the shipped model is unchanged):

  --friction MU   every geom's sliding friction set to MU
  --sole-grid     each foot plate's collision replaced by a 5 x 3 grid of 2 mm spheres under
                  the sole (a distributed contact instead of box-plane corner points)
  --contact-timeconst S
                  every geom's contact time constant (solref[0]; MuJoCo's default 0.02 s):
                  smaller is a harder floor
  --elliptic      elliptic friction cones instead of MuJoCo's default pyramidal ones

and, for the gait, --set GROUP.FIELD=VALUE (repeatable) on top of the preset. --yaw-per-ca K
walks each CA with a_y = K * CA added (a_y > 0 turns clockwise, as CA > 0 does): the steering
term of docs/DESIGN.md §4 (`steer.yaw_per_ca`), emulated on the motion vector.

    python bench/ca_response.py [--preset tuned] [--a-p 0.07] [--duration 30] \
        [--friction 0.5] [--sole-grid] [--contact-timeconst 0.005] [--elliptic] \
        [--set swing.v=3.0 --set swing.o=0.226] [--yaw-per-ca 0.15] [--json PATH]

Writes its figures (per CA of the sweep: the heading rate, eq (13)'s, a fall; the pair's gain
and bend; V at CA = 0) to bench/results/<bench>.json, or to --json PATH (bench/results.py).
"""

from __future__ import annotations

import argparse

import mujoco
import results

from app.analysis.cases import steering
from app.evaluation import BatchEvaluator, Job
from app.robots import build_spec, load_description
from app.robots.model import RobotModel
from app.study.report import fmt
from app.study.walks import resolve_presets
from gait import GaitParams, Motion
from gait.params import merge, parse_settings

WARMUP_S = 4.0  # of each run's --duration, not measured
SWEEP = (-0.2, -0.15, -0.1, -0.05, -0.025, 0.0, 0.025, 0.05, 0.1, 0.15, 0.2)
GRID_X_M = (-0.056, -0.028, 0.0, 0.028, 0.056)
GRID_Y_M = (-0.031, 0.0, 0.031)


def sole_grid_spec(spec: mujoco.MjSpec) -> mujoco.MjSpec:
    """The model with each foot plate visual only and a grid of small spheres as its sole."""
    for side in ("l", "r"):
        plate = spec.geom(f"{side}_foot_plate")
        if plate is None:
            raise ValueError(f"no {side}_foot_plate geom in the model")
        z = plate.pos[2]
        sphere = {"contype": plate.contype, "conaffinity": plate.conaffinity}
        sphere |= {"condim": plate.condim, "friction": list(plate.friction)}
        plate.contype = plate.conaffinity = 0
        for i, x in enumerate(GRID_X_M):
            for j, y in enumerate(GRID_Y_M):
                plate.parent.add_geom(
                    name=f"{side}_sole_{i}{j}",
                    type=mujoco.mjtGeom.mjGEOM_SPHERE,
                    size=[0.002, 0, 0],
                    pos=[x, y, z],
                    mass=0,
                    group=3,
                    **sphere,
                )
    return spec


def load_robot(
    friction: float | None,
    sole_grid: bool,
    contact_timeconst_s: float | None = None,
    elliptic: bool = False,
) -> RobotModel:
    description = load_description()
    spec = build_spec(description)
    if sole_grid:
        spec = sole_grid_spec(spec)
    robot = RobotModel.of_model(description, spec.compile())
    if friction is not None:
        robot.model.geom_friction[:, 0] = friction
    if contact_timeconst_s is not None:
        robot.model.geom_solref[:, 0] = contact_timeconst_s
    if elliptic:
        robot.model.opt.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    return robot


def describe_variant(args: argparse.Namespace) -> str:
    parts = [f"friction {args.friction if args.friction is not None else 'as built'}"]
    parts.append("sole grid" if args.sole_grid else "box soles")
    if args.contact_timeconst is not None:
        parts.append(f"contact time constant {args.contact_timeconst:g} s")
    if args.elliptic:
        parts.append("elliptic cones")
    parts += [f"gait {s}" for s in args.set]
    if args.yaw_per_ca:
        parts.append(f"a_y = {args.yaw_per_ca:g} CA")
    return ", ".join(parts)


def add_variant_arguments(parser: argparse.ArgumentParser) -> None:
    """The preset, walking amplitude and model/gait variant options both experiments share."""
    parser.add_argument("--preset", default="tuned", help="built-in preset name or a file")
    parser.add_argument("--a-p", type=float, default=0.07)
    parser.add_argument("--friction", type=float, default=None)
    parser.add_argument("--sole-grid", action="store_true")
    parser.add_argument("--contact-timeconst", type=float, default=None, metavar="S")
    parser.add_argument("--elliptic", action="store_true")
    parser.add_argument("--set", action="append", default=[], metavar="GROUP.FIELD=VALUE")
    parser.add_argument("--yaw-per-ca", type=float, default=0.0, metavar="K")


def load_variant(args: argparse.Namespace) -> tuple[GaitParams, RobotModel]:
    """The preset's gait with the --set overrides, and the model with the variant options."""
    try:
        (preset,), _notes = resolve_presets([args.preset])
        params = merge(preset.params, parse_settings(args.set))
    except ValueError as err:
        raise SystemExit(f"ca_response: {err}") from None
    robot = load_robot(args.friction, args.sole_grid, args.contact_timeconst, args.elliptic)
    return params, robot


def walking(args: argparse.Namespace, ca: float) -> Motion:
    """Forward at --a-p with this CA, plus a_y = --yaw-per-ca x CA."""
    return Motion(a_p=args.a_p, a_y=args.yaw_per_ca * ca, ca=ca)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    add_variant_arguments(parser)
    parser.add_argument("--duration", type=float, default=30.0, help="s per run, warm-up included")
    args = results.parse_args(parser)
    params, robot = load_variant(args)
    jobs = [Job(params, walking(args, ca)) for ca in SWEEP]
    metrics = BatchEvaluator(robot).evaluate(jobs, duration_s=args.duration, warmup_s=WARMUP_S)
    print(
        f"preset {args.preset}, a_p = {args.a_p:+.3f}, {args.duration:g} s runs; "
        f"{describe_variant(args)}"
    )
    print("   CA    turn    eq13  (deg/s, + = counter-clockwise)")
    sweep = []
    for ca, m in zip(SWEEP, metrics, strict=True):
        measured = not m["fell"] and m["turn_deg_s"] is not None
        sweep.append(
            {
                "ca": ca,
                "a_y": args.yaw_per_ca * ca,
                "fell": m["fell"],
                "fall_time_s": m.get("fall_time_s"),
                "measured": measured,
                "turn_deg_s": m["turn_deg_s"] if measured else None,
                "eq13_turn_deg_s": m["predicted_turn_deg_s"] if measured else None,
                "forward_cm_s": m["forward_cm_s"] if measured else None,
            }
        )
        if m["fell"]:
            print(f"{ca:+.3f}  fell at {m['fall_time_s']} s")
            continue
        if m["turn_deg_s"] is None:
            print(f"{ca:+.3f}  nothing measured after the {WARMUP_S:g} s warm-up: run longer")
            continue
        print(f"{ca:+.3f}  {m['turn_deg_s']:+6.2f}  {fmt(m['predicted_turn_deg_s'], '+6.2f')}")
    by_ca = dict(zip(SWEEP, metrics, strict=True))
    s = steering(by_ca[0.1], by_ca[-0.1], by_ca[0.0])
    if s is None:
        print("CA = +-0.1: no steering figure (a run fell, or was not measured)")
    else:
        print(f"CA = +-0.1: gain {s.gain:.2f} (eq (13): 1), bend {s.bend:+.2f} (linear: 0)")
        print(f"V (CA = 0) {fmt(by_ca[0.0]['forward_cm_s'])} cm/s")
    pair = None if s is None else {"gain": s.gain, "bend": s.bend}
    straight_cm_s = by_ca[0.0]["forward_cm_s"] if sweep[SWEEP.index(0.0)]["measured"] else None
    figures = {
        "variant": describe_variant(args),
        "warmup_s": WARMUP_S,
        "sweep": sweep,
        "pair_ca_0.1": pair,
        "forward_cm_s_at_ca_0": straight_cm_s,
    }
    headline = {
        "steering gain, CA ±0.1 (eq 13: 1)": None if s is None else s.gain,
        "bend, CA ±0.1 (linear: 0)": None if s is None else s.bend,
        "turn at CA +0.1 (deg/s)": sweep[SWEEP.index(0.1)]["turn_deg_s"],
        "V at CA 0 (cm/s)": straight_cm_s,
        "falls (of 11 runs)": sum(row["fell"] for row in sweep),
    }
    results.write("ca_response", args, figures, headline)


if __name__ == "__main__":
    main()
