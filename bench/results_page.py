"""Renders bench/RESULTS.md from the results the benches wrote (bench/results/*.json).

    python bench/results_page.py            # rewrite bench/RESULTS.md
    python bench/results_page.py --check    # exit 1 (and show the difference) if it is stale
    python bench/results_page.py --results DIR --out FILE

The page lists each bench's headline figures with the machine, engine version and date they were
measured on and the command that gives them, then the benches with no result yet. Nobody edits
it by hand: tests/test_bench_results.py checks it is what this script renders from the files.
"""

from __future__ import annotations

import argparse
import ast
import difflib
import json
import re
import sys
from pathlib import Path
from typing import Any

BENCH_DIR = Path(__file__).resolve().parent
RESULTS_DIR = BENCH_DIR / "results"
PAGE = BENCH_DIR / "RESULTS.md"
#: modules in bench/ that are no benches: this script and the helper the benches write with
HELPERS = ("batch_measures", "results", "results_page")


def benches(bench_dir: Path = BENCH_DIR) -> list[str]:
    """Every bench's name: the scripts in bench/, the helpers left out."""
    return sorted(p.stem for p in bench_dir.glob("*.py") if p.stem not in HELPERS)


def usage(name: str, bench_dir: Path = BENCH_DIR) -> str:
    """The bench's command line as its docstring gives it (its first line naming the script,
    options in brackets left out), or the bare command."""
    tree = ast.parse((bench_dir / f"{name}.py").read_text(encoding="utf-8"))
    command = f"python bench/{name}.py"
    for line in (ast.get_docstring(tree) or "").splitlines():
        if line.strip().startswith(command):
            return re.sub(r" *\[[^\]]*\]", "", line.split("#")[0]).strip()
    return command


def load(results_dir: Path) -> list[dict[str, Any]]:
    """The results documents in `results_dir`, by bench name."""
    docs = []
    for path in sorted(results_dir.glob("*.json")):
        doc = json.loads(path.read_text(encoding="utf-8"))
        if not isinstance(doc, dict) or "bench" not in doc or "headline" not in doc:
            raise SystemExit(f"{path} is no bench results document (bench/results.py)")
        docs.append(doc)
    return sorted(docs, key=lambda d: d["bench"])


def number(value: Any) -> str:
    """A figure as the page shows it."""
    if value is None:
        return "–"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if abs(value) >= 1000:
            return f"{value:.0f}"
        if abs(value) >= 10:
            return f"{value:.1f}"
        return f"{value:.3f}"
    return str(value)


def cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def where(doc: dict[str, Any]) -> str:
    """The machine, engine and date of a run, on one line."""
    env = doc["environment"]
    machine = env["machine"]
    commit = env.get("git_commit")
    checkout = "no git checkout"
    if commit:
        checkout = f"commit {commit[:10]}" + (" with changes" if env.get("git_changes") else "")
    return (
        f"{env['finished_utc'].replace('T', ' ').replace('+00:00', ' UTC')}; "
        f"{machine['cpu_model']}, {machine['logical_cpus']} logical CPUs, {machine['platform']}; "
        f"MuJoCo {env['mujoco']}, numpy {env['numpy']}, Python {env['python']}; "
        f"artro-gait-studio {env['project_version']}, {checkout}"
    )


def render(docs: list[dict[str, Any]], names: list[str]) -> str:
    """The page: a summary table, each bench's headline figures, the benches without results."""
    lines = [
        "# Benchmark and experiment results",
        "",
        "The headline figures each bench in `bench/` last wrote to `bench/results/<bench>.json`",
        "(with `bench/results.py`; the file holds every figure, the arguments, the machine and",
        "the versions). Rendered by `python bench/results_page.py`: do not edit by hand,",
        "`tests/test_bench_results.py` checks that the page is what the files render.",
        "",
    ]
    if docs:
        lines += [
            "| bench | measured (UTC) | machine | MuJoCo | command |",
            "| --- | --- | --- | --- | --- |",
        ]
        for doc in docs:
            env = doc["environment"]
            date = env["finished_utc"][:10]
            machine = f"{env['machine']['cpu_model']}, {env['machine']['logical_cpus']} CPUs"
            lines.append(
                f"| [{doc['bench']}](#{doc['bench']}) | {date} | {cell(machine)} | "
                f"{env['mujoco']} | `{cell(doc['command'])}` |"
            )
        lines.append("")
    for doc in docs:
        lines += [f"## {doc['bench']}", "", f"`{doc['command']}`", "", where(doc), ""]
        lines += ["| figure | value |", "| --- | ---: |"]
        lines += [f"| {cell(k)} | {number(v)} |" for k, v in doc["headline"].items()]
        lines.append("")
    missing = [n for n in names if n not in {d["bench"] for d in docs}]
    if missing:
        lines += ["## No result yet", ""]
        lines += [f"- `{n}`: `{usage(n)}`" for n in missing]
        lines += [
            "",
            "The speed benchmarks (`bench_*`) measure the machine: run them on a quiet one.",
            "",
        ]
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--results", type=Path, default=RESULTS_DIR, help="the JSON files' folder")
    parser.add_argument("--out", type=Path, default=PAGE, help="the page to write")
    parser.add_argument("--check", action="store_true", help="only say whether the page is stale")
    args = parser.parse_args()
    page = render(load(args.results), benches())
    if args.check:
        current = args.out.read_text(encoding="utf-8") if args.out.exists() else ""
        if current == page:
            return 0
        sys.stdout.writelines(
            difflib.unified_diff(
                current.splitlines(keepends=True),
                page.splitlines(keepends=True),
                str(args.out),
                "rendered from " + str(args.results),
            )
        )
        print(f"\n{args.out} is not what the results render: run python bench/results_page.py")
        return 1
    args.out.write_text(page, encoding="utf-8")
    print(f"wrote {args.out} ({len(load(args.results))} results)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
