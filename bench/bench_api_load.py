"""Benchmark (issue 13): eight clients polling `GET /api/scope?frames=250` and two scope sockets
against a real server process for N s; prints the real-time factor (min/mean of `/api/state`,
goal >= 0.98), skipped and lost frames, polls answered and the server's CPU.

    python bench/bench_api_load.py [--seconds 20] [--pollers 8] [--sockets 2] [--pythonpath DIR]
        [--json PATH]

Writes the figures to bench/results/<bench>.json, or to --json PATH (bench/results.py).
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path
from tempfile import TemporaryDirectory

import httpx
import results
from websockets.sync.client import connect

GOAL = 0.98
SERVER = """
import sys, uvicorn
from pathlib import Path
from app.server.http.app import create_app
from app.server.services import ServerConfig
port, data = int(sys.argv[1]), Path(sys.argv[2])
app = create_app(ServerConfig(port=port, data_dir=data, viewer=False))
uvicorn.run(app, host="127.0.0.1", port=port, log_level="warning")
"""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def cpu_s(pid: int) -> float:
    """User + system CPU seconds of a process (Linux /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def wait_ready(base: str, timeout_s: float = 60.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            if httpx.get(base + "/api/health", timeout=2).status_code == 200:
                return
        except httpx.HTTPError:
            pass
        time.sleep(0.2)
    raise RuntimeError("the server did not start")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--pollers", type=int, default=8)
    parser.add_argument("--sockets", type=int, default=2)
    parser.add_argument("--frames", type=int, default=250)
    parser.add_argument("--warmup", type=float, default=5.0, help="s before measuring")
    parser.add_argument("--pythonpath", default=str(Path(__file__).resolve().parents[1]))
    args = results.parse_args(parser)

    port = free_port()
    base = f"http://127.0.0.1:{port}"
    env = os.environ | {"PYTHONPATH": args.pythonpath}
    with TemporaryDirectory() as data:
        server = subprocess.Popen(  # cwd too: `python -c` puts it first on sys.path
            [sys.executable, "-c", SERVER, str(port), data], env=env, cwd=args.pythonpath
        )
        try:
            wait_ready(base)
            time.sleep(args.warmup)  # the simulation settles, the first frames fill the history
            report = load(base, server.pid, args)
        finally:
            server.terminate()
            server.wait(10)
    print(json.dumps(report, indent=2))
    verdict = "meets" if report["rtf_min"] >= GOAL else "misses"
    print(f"RTF min {report['rtf_min']:.3f}, mean {report['rtf_mean']:.3f}: {verdict} {GOAL}")
    headline = {
        f"real-time factor, min (goal ≥ {GOAL})": report["rtf_min"],
        "real-time factor, mean": report["rtf_mean"],
        "polls answered (/s)": report["polls_per_s"],
        "scope frames lost": sum(report["ws_frames_lost"]),
        "server CPU (% of one core)": report["server_cpu_pct_of_one_core"],
    }
    results.write("bench_api_load", args, {**report, "goal_rtf_min": GOAL}, headline)


def load(base: str, pid: int, args: argparse.Namespace) -> dict:
    stop = threading.Event()
    polls = [0] * args.pollers
    polled_bytes = [0] * args.pollers
    lost = [0] * args.sockets
    received = [0] * args.sockets

    def poller(i: int) -> None:
        with httpx.Client(base_url=base, timeout=30) as http:
            while not stop.is_set():
                response = http.get("/api/scope", params={"frames": args.frames})
                response.raise_for_status()
                polls[i] += 1
                polled_bytes[i] += len(response.content)

    def watcher(i: int) -> None:
        url = base.replace("http://", "ws://") + "/ws/scope"
        with connect(url, open_timeout=10, max_size=None) as ws:
            last = None
            while not stop.is_set():
                frame = json.loads(ws.recv(timeout=10))["frame"]
                if last is not None and frame > last + 1:
                    lost[i] += frame - last - 1
                last = frame
                received[i] += 1

    threads = [threading.Thread(target=poller, args=(i,)) for i in range(args.pollers)]
    threads += [threading.Thread(target=watcher, args=(i,)) for i in range(args.sockets)]
    with httpx.Client(base_url=base, timeout=30) as http:
        before = http.get("/api/state").json()
        cpu0, t0 = cpu_s(pid), time.monotonic()
        for thread in threads:
            thread.start()
        rtfs = []
        while time.monotonic() - t0 < args.seconds:
            time.sleep(0.5)
            rtf = http.get("/api/state").json()["rtf"]
            if rtf is not None:
                rtfs.append(rtf)
        stop.set()
        for thread in threads:
            thread.join(30)
        wall = time.monotonic() - t0
        cpu = cpu_s(pid) - cpu0
        after = http.get("/api/state").json()
    return {
        "seconds": round(wall, 1),
        "pollers": args.pollers,
        "frames_per_poll": args.frames,
        "sockets": args.sockets,
        "rtf_min": min(rtfs),
        "rtf_mean": statistics.fmean(rtfs),
        "rtf_samples": len(rtfs),
        "sim_frames_skipped": after["frames_dropped"] - before["frames_dropped"],
        "sim_s": round(after["sim_time_s"] - before["sim_time_s"], 2),
        "polls_per_s": round(sum(polls) / wall, 1),
        "kib_per_poll": round(sum(polled_bytes) / max(sum(polls), 1) / 1024, 1),
        "ws_frames_received": received,
        "ws_frames_lost": lost,
        "server_cpu_pct_of_one_core": round(100 * cpu / wall, 1),
    }


if __name__ == "__main__":
    main()
