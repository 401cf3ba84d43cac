"""Where robustness and the paper's figures pull apart (docs/DESIGN.md §12): every candidate of a
`tune --robust` study, the share of its varied runs that pass against its largest error from the
paper's table on the nominal model, with the goal lines (>= 90 % passing; within 25 %) and the
candidates no other beats on both (the frontier).

    python bench/robust_frontier.py out/tune/robust2.log [--png out/tune/frontier.png]
        [--study-name NAME] [--save TRIAL --out FILE] [--json PATH]

Prints the frontier as a table; the PNG draws every candidate, coloured by generation. The pass
share here is over all cases of the study's worlds together, each generation on its own worlds
(per case and on common worlds: `artro bench robust --presets FILE`). `--save` writes one
trial's set as a parameter-set file (the study's base with the trial's values), to bench, steer
(`artro calibrate-ca`) or load in the dashboard. The frontier (every candidate on it, and how
many candidates there were) goes to bench/results/<bench>.json, or to --json PATH
(bench/results.py); --save writes no results.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import optuna
import results
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from app.analysis.cases import CASES, measured, target
from app.params.document import ParameterSet
from app.params.formats import load_parameter_set
from app.params.presets import builtin_presets, stamped, write_parameter_set
from app.study.study_store import open_storage
from app.study.tune_space import dimensions, with_values

PASS_GOAL = 0.9
PAPER_TOLERANCE = 0.25


def worst_paper_error(nominal: dict) -> float:
    """The largest relative error from the paper's figures over the moving cases (a fall: inf)."""
    worst = 0.0
    for case in CASES:
        m = nominal.get(case.name)
        if case.paper == 0.0 or m is None:
            continue
        value = measured(case, m)
        if m["fell"] or value is None:
            return float("inf")
        worst = max(worst, abs(value - target(case)) / abs(target(case)))
    return worst


def load(store: str, name: str | None = None) -> optuna.Study:
    """The study `name` in `store`, by default its only one (`artro tune` names each
    tune-ROBOT-DIGEST); SystemExit naming the studies there when that is not one study."""
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    storage = open_storage(Path(store))
    names = [s.study_name for s in optuna.get_all_study_summaries(storage)]
    if name is None and len(names) == 1:
        name = names[0]
    if name not in names:
        asked = f"no study {name!r}" if name else f"{len(names)} studies"
        there = ", ".join(names) or "none"
        raise SystemExit(f"{store}: {asked}; give --study-name, one of: {there}")
    return optuna.load_study(study_name=name, storage=storage)


def save_trial(study: optuna.Study, number: int, path: Path, base: str | None) -> ParameterSet:
    """Trial `number`'s set: the study's base (a built-in name or a file; by default the name
    the study recorded) with the trial's point, as a preset file named after the file."""
    trial = next((t for t in study.get_trials() if t.number == number), None)
    if trial is None or "unit" not in trial.user_attrs:
        raise SystemExit(f"the study has no finished trial {number}")
    settings = study.user_attrs["settings"]
    base = base or settings["base"]
    shelf = builtin_presets()
    if base in shelf:
        gait = shelf[base].gait
    elif Path(base).is_file():
        gait = load_parameter_set(base).gait
    else:
        raise SystemExit(f"the study's base {base!r} is no built-in preset: give it as --base FILE")
    unit = np.array(trial.user_attrs["unit"], dtype=float)
    tuned = with_values(gait, dimensions(settings["names"]), unit)
    pset = stamped(ParameterSet(name=path.stem, gait=tuned), path.stem)
    write_parameter_set(path, pset)
    return pset


def candidates(study: optuna.Study) -> list[dict]:
    out = []
    for trial in study.get_trials(states=(optuna.trial.TrialState.COMPLETE,)):
        metrics = trial.user_attrs["metrics"]
        robust = metrics.get("robust")
        if not robust or "passed" not in robust:
            continue  # a study without --robust, or from before pass counts were kept
        out.append(
            {
                "number": trial.number,
                "generation": trial.user_attrs.get("generation", 0),
                "loss": trial.value,
                "pass_share": robust["passed"] / robust["runs"],
                "paper_error": worst_paper_error(metrics["nominal"]),
                "params": trial.params,
            }
        )
    return out


def frontier(rows: list[dict]) -> list[dict]:
    """The candidates no other passes more often with a smaller paper error."""
    finite = sorted((r for r in rows if r["paper_error"] != float("inf")),
                    key=lambda r: (r["paper_error"], -r["pass_share"]))  # fmt: skip
    best, out = -1.0, []
    for row in finite:
        if row["pass_share"] > best:
            out.append(row)
            best = row["pass_share"]
    return out


def plot(rows: list[dict], front: list[dict], path: Path) -> None:
    fig = Figure(figsize=(7.5, 5.0), dpi=110)
    ax = fig.add_subplot()
    shown = [r for r in rows if r["paper_error"] != float("inf")]
    points = ax.scatter(
        [100 * r["paper_error"] for r in shown],
        [100 * r["pass_share"] for r in shown],
        c=[r["generation"] for r in shown],
        cmap="viridis",
        s=18,
    )
    fig.colorbar(points, ax=ax, label="generation")
    ax.plot(
        [100 * r["paper_error"] for r in front],
        [100 * r["pass_share"] for r in front],
        "-o",
        color="tab:red",
        mfc="none",
        label="frontier (no candidate better on both)",
    )
    ax.axhline(100 * PASS_GOAL, color="tab:green", ls="--", label="goal: 90 % of runs pass")
    ax.axvline(100 * PAPER_TOLERANCE, color="tab:gray", ls="--", label="paper table within 25 %")
    ax.set_xlabel("largest error from the paper's table, nominal model (%)")
    ax.set_ylabel("varied runs that pass (%)")
    ax.set_xlim(0, min(100, max([100 * r["paper_error"] for r in shown] + [30]) * 1.05))
    ax.set_ylim(0, 100)
    ax.set_title(f"robustness against the paper's figures: {len(rows)} candidates")
    ax.legend(loc="lower right", fontsize=8)
    ax.grid(alpha=0.3)
    FigureCanvasAgg(fig).print_png(path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("store", help="the study store (journal file) of a tune --robust")
    parser.add_argument("--png", default="out/tune/frontier.png")
    parser.add_argument("--save", type=int, metavar="TRIAL", help="write this trial's set")
    parser.add_argument("--out", metavar="FILE", help="where --save writes (a .json file)")
    parser.add_argument("--base", help="the study's base set, if not a built-in (for --save)")
    parser.add_argument("--study-name", help="the study in the store (default: its only one)")
    args = results.parse_args(parser)
    if (args.save is None) != (args.out is None):
        parser.error("--save TRIAL and --out FILE go together")
    study = load(args.store, args.study_name)
    if args.save is not None:
        pset = save_trial(study, args.save, Path(args.out), args.base)
        print(f"wrote trial {args.save} as {args.out} ('{pset.name}')")
        return
    rows = candidates(study)
    if not rows:
        raise SystemExit(f"{args.store} holds no tune --robust candidate with pass counts")
    front = frontier(rows)
    falls = sum(r["paper_error"] == float("inf") for r in rows)
    print(f"{len(rows)} candidates, {falls} of them fall or stand still on the nominal model")
    print("frontier: trial  generation  paper error  varied runs passing  loss")
    for r in front:
        print(
            f"          {r['number']:5d}  {r['generation']:10d}  {100 * r['paper_error']:10.1f} %"
            f"  {100 * r['pass_share']:18.1f} %  {r['loss']:.3f}"
        )
    Path(args.png).parent.mkdir(parents=True, exist_ok=True)
    plot(rows, front, Path(args.png))
    print(f"wrote {args.png}")
    figures = {
        "store": args.store,
        "candidates": len(rows),
        "fall_or_stand_still": falls,
        "goals": {"pass_share_pct": 100 * PASS_GOAL, "paper_error_pct": 100 * PAPER_TOLERANCE},
        "frontier": [
            {
                "trial": r["number"],
                "generation": r["generation"],
                "paper_error_pct": 100 * r["paper_error"],
                "pass_share_pct": 100 * r["pass_share"],
                "loss": r["loss"],
                "params": r["params"],
            }
            for r in front
        ],
        "png": args.png,
    }
    meeting = [r for r in front if r["pass_share"] >= PASS_GOAL]
    headline = {
        "candidates": len(rows),
        "on the frontier": len(front),
        "smallest paper error with ≥ 90 % passing (%)": min(
            (100 * r["paper_error"] for r in meeting), default=None
        ),
        "largest pass share on the frontier (%)": max(
            (100 * r["pass_share"] for r in front), default=None
        ),
    }
    results.write("robust_frontier", args, figures, headline)


if __name__ == "__main__":
    main()
