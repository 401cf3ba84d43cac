"""Where robustness and the paper's figures pull apart (docs/DESIGN.md §13): every candidate of a
`tune --robust` study, the share of its varied runs that pass against its largest error from the
paper's table on the nominal model, with the goal lines (>= 90 % passing; within 25 %) and the
candidates no other beats on both (the frontier).

    python bench/robust_frontier.py out/tune/robust2.log [--png out/tune/frontier.png]

Prints the frontier as a table; the PNG draws every candidate, coloured by generation. The pass
share here is over all cases of the study's worlds together (per case, `artro bench robust`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import optuna
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from app.study.cases import CASES, measured, target
from app.study.study_store import DEFAULT_STUDY, open_storage

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


def candidates(store: str) -> list[dict]:
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.load_study(study_name=DEFAULT_STUDY, storage=open_storage(Path(store)))
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
    args = parser.parse_args()
    rows = candidates(args.store)
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


if __name__ == "__main__":
    main()
