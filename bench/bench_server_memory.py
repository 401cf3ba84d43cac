"""Benchmark (decision 0048): the server's resident memory over rounds of background jobs, each
a robustness job and an axle fit started on a real server process and cancelled once they have
simulated; prints the RSS at the start, every 10 rounds and at the end, and the growth per round
over the second half (goal: none beyond the allocator's noise, < 0.5 MiB a round).

    python bench/bench_server_memory.py [--rounds 40] [--pythonpath DIR] [--json PATH]

Writes the figures to bench/results/<bench>.json, or to --json PATH (bench/results.py).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path
from tempfile import TemporaryDirectory

import httpx
import results
from bench_api_load import SERVER, free_port, wait_ready

GOAL_MIB_PER_ROUND = 0.5
JOBS = (("robustness", {"samples": 4}), ("axle-fit", None))


def rss_mib(pid: int) -> float:
    """The process's resident set (Linux /proc)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS")


def started_and_cancelled(http: httpx.Client, kind: str, body: dict | None) -> str:
    """Start a job of `kind`, let it simulate (progress > 0, or 3 s), cancel it; its status."""
    job = http.post(f"/api/jobs/{kind}", json=body)
    job.raise_for_status()
    job_id = job.json()["id"]
    deadline = time.monotonic() + 3.0
    while time.monotonic() < deadline:
        state = http.get(f"/api/jobs/{job_id}").json()
        if state["status"] != "running" or (state.get("progress") or 0) > 0:
            break
        time.sleep(0.05)
    http.delete(f"/api/jobs/{job_id}")
    while (status := http.get(f"/api/jobs/{job_id}").json()["status"]) == "running":
        time.sleep(0.05)
    return status


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=40)
    parser.add_argument("--pythonpath", default=str(Path(__file__).resolve().parents[1]))
    args = results.parse_args(parser)

    port = free_port()
    base = f"http://127.0.0.1:{port}"
    env = os.environ | {"PYTHONPATH": args.pythonpath}
    rss, statuses = [], []
    with TemporaryDirectory() as data:
        server = subprocess.Popen(  # cwd too: `python -c` puts it first on sys.path
            [sys.executable, "-c", SERVER, str(port), data], env=env, cwd=args.pythonpath
        )
        try:
            wait_ready(base)
            rss.append(rss_mib(server.pid))
            with httpx.Client(base_url=base, timeout=60) as http:
                for done in range(1, args.rounds + 1):
                    statuses += [started_and_cancelled(http, kind, body) for kind, body in JOBS]
                    rss.append(rss_mib(server.pid))
                    if done % 10 == 0:
                        print(f"round {done}: RSS {rss[-1]:.1f} MiB", flush=True)
        finally:
            server.terminate()
            server.wait(10)
    half = rss[len(rss) // 2 :]
    slope = statistics.linear_regression(range(len(half)), half).slope if len(half) > 1 else 0.0
    report = {
        "rounds": args.rounds,
        "jobs_per_round": [kind for kind, _ in JOBS],
        "statuses": {s: statuses.count(s) for s in sorted(set(statuses))},
        "rss_mib_start": round(rss[0], 1),
        "rss_mib_end": round(rss[-1], 1),
        "rss_mib_max": round(max(rss), 1),
        "rss_mib_every_round": [round(r, 1) for r in rss],
        "mib_per_round_second_half": round(slope, 3),
    }
    print(json.dumps({k: v for k, v in report.items() if k != "rss_mib_every_round"}, indent=2))
    verdict = "meets" if slope < GOAL_MIB_PER_ROUND else "misses"
    print(f"{slope:+.3f} MiB a round over the second half: {verdict} < {GOAL_MIB_PER_ROUND}")
    headline = {
        "RSS at start (MiB)": report["rss_mib_start"],
        "RSS at end (MiB)": report["rss_mib_end"],
        f"growth per round, second half (MiB, goal < {GOAL_MIB_PER_ROUND})": slope,
    }
    results.write("bench_server_memory", args, {**report, "goal": GOAL_MIB_PER_ROUND}, headline)


if __name__ == "__main__":
    main()
