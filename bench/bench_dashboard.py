"""Benchmark: the running dashboard, as users load it.

Starts `artro serve` as a real process, opens N dashboard pages in headless Chromium (each one a
client of the scope WebSocket and of the embedded viser 3D view), and for `--seconds` measures:
  - real-time factor: simulated / wall time over the whole window, and the worst 2 s window;
  - scope frames per second received by each page (counted in the page: window.artro);
  - server CPU, % of one core (from /proc/<pid>/stat);
  - parameter change -> servo latency: 20 changes of a_p through the API; the server counts, for
    each, the 20 ms frames from the change entering the parameter store to the first frame built
    with it (the servos receive it at that frame's pulse falling edges, within the frame).

    python bench/bench_dashboard.py [--clients 2] [--seconds 60] [--no-3d] [--drive firmware]
                                    [--cycle-view] [--ghost PRESET] [--json PATH]

--no-3d opens the pages with the 3D view hidden (the iframe is removed), to separate what
software WebGL rendering in headless Chromium costs on this machine from the server's own load.
--ghost PRESET lets that preset walk beside the robot (the A/B ghost: a second simulated robot,
drawn in every 3D view, its metrics in every page). --cycle-view shows the scope's cycle-folded
plots (mean ± band over the gait phase) in every page instead of the single frame.
--drive firmware serves with the robot's firmware on the emulated
ATmega128 making the pulses; the changes then travel over its emulated UART (57600 baud), which
the latency includes. Writes the figures to bench/results/<bench>.json, or to --json PATH
(bench/results.py).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx
import results

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # the tests' shared harness
from tests.testing.server_harness import CHROMIUM, CHROMIUM_ARGS, free_port


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--clients", type=int, default=2)
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--no-3d", action="store_true", help="hide the embedded 3D view")
    parser.add_argument("--drive", choices=("model", "firmware"), default="model")
    parser.add_argument("--cycle-view", action="store_true", help="the scope's folded plots")
    parser.add_argument("--ghost", metavar="PRESET", help="an A/B ghost walking this preset")
    args = results.parse_args(parser)

    port, viser_port = free_port(), free_port()
    data_dir = tempfile.mkdtemp(prefix="artro-bench-")
    artro = Path(sys.executable).with_name("artro")
    server = subprocess.Popen(
        [str(artro), "serve", "--port", str(port), "--viser-port", str(viser_port),
         "--data-dir", data_dir, "--drive", args.drive],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    base = f"http://127.0.0.1:{port}"
    http = httpx.Client(base_url=base, timeout=10)
    try:
        assert server.stdout is not None
        server.stdout.readline()  # the URL line: printed before uvicorn binds
        deadline = time.monotonic() + 30
        while True:
            try:
                http.get("/api/health")
                break
            except httpx.TransportError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.2)  # the server is still binding its port: try again
        http.patch("/api/params", json={"motion": {"a_p": 0.07}})
        if args.ghost:
            http.put("/api/ghost", json={"preset": args.ghost}).raise_for_status()
        figures = run(args, base, http, server.pid)
    finally:
        server.terminate()
        server.wait(10)
    headline = {
        "real-time factor": figures["rtf"],
        "real-time factor, worst 2 s window": figures["rtf_window_min"],
        "scope frames/s, slowest page": min(figures["page_scope_frames_per_s"]),
        "server CPU (% of one core)": figures["server_cpu_pct_of_one_core"],
        "change → servos, median (frames)": figures["change_latency_frames"]["median"],
    }
    results.write("bench_dashboard", args, figures, headline)


def run(args: argparse.Namespace, base: str, http: httpx.Client, pid: int) -> dict:
    """Measures with the pages open, prints the figures and returns them."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        pages = []
        for _ in range(args.clients):
            page = browser.new_context(viewport={"width": 1600, "height": 1000}).new_page()
            page.goto(base + "/")
            if args.no_3d:
                page.evaluate("document.getElementById('viser-frame')?.remove()")
            if args.cycle_view:
                page.click("#scope-mode-cycle")
            pages.append(page)
        for page in pages:  # every page is receiving scope frames before the clock starts
            page.wait_for_function("window.artro && window.artro.framesReceived > 0", timeout=30000)
        # (frames, page clock in ms) read in each page: its rate over its own interval
        count = "[window.artro.framesReceived, performance.now(), window.artro.lastFrame.frame]"
        page_start = [pg.evaluate(count) for pg in pages]
        state0, wall0, cpu0 = http.get("/api/state").json(), time.monotonic(), cpu_seconds(pid)
        windows = []
        end = wall0 + args.seconds
        while time.monotonic() < end:
            time.sleep(1.0)  # the sampling period of the measurement
            rtf = http.get("/api/state").json()["rtf"]
            if rtf is not None:
                windows.append(rtf)
        state1, wall1, cpu1 = http.get("/api/state").json(), time.monotonic(), cpu_seconds(pid)
        page_end = [pg.evaluate(count) for pg in pages]
        for i in range(20):  # parameter changes, 0.1 s apart, while the pages keep watching
            http.patch("/api/params", json={"motion": {"a_p": 0.06 + 0.002 * (i % 5)}})
            time.sleep(0.1)
        latency = http.get("/api/state").json()["param_latency_frames"]
        browser.close()

    wall = wall1 - wall0
    rtf = (state1["sim_time_s"] - state0["sim_time_s"]) / wall
    spans = list(zip(page_start, page_end, strict=True))
    page_fps = [1000.0 * (e[0] - s[0]) / (e[1] - s[1]) for s, e in spans]
    numbered = [(e[2] - s[2], e[0] - s[0]) for s, e in spans]  # frame numbers advanced, received
    view = " (3D view removed)" if args.no_3d else " (with the 3D view)"
    view += ", scope in the cycle-folded view" if args.cycle_view else ""
    view += f", ghost {args.ghost} walking beside" if args.ghost else ""
    print(f"dashboard clients   : {args.clients} headless Chromium pages{view}, {wall:.0f} s")
    print(
        f"real-time factor    : {rtf:.3f} over the window; 2 s windows min {min(windows):.3f}"
        f" max {max(windows):.3f}; frames dropped catching up: "
        f"{state1['frames_dropped'] - state0['frames_dropped']}"
    )
    print("scope frames/s      : " + ", ".join(f"{f:.1f}" for f in page_fps) + " (per page)")
    print(
        "frame numbers       : "
        + ", ".join(f"{n} advanced / {r} received" for n, r in numbered)
        + " (per page, over its own interval)"
    )
    print(f"server CPU          : {100 * (cpu1 - cpu0) / wall:.1f} % of one core")
    if state1.get("firmware"):
        fw = state1["firmware"]
        print(
            f"pulses from         : the firmware on the emulated ATmega128, MCU busy at most "
            f"{fw['busy_cycles_max']} cycles of the 320 000-cycle frame (last second)"
        )
    print(
        f"change -> servos    : median {latency['median']} frames, max {latency['max']} frames "
        f"over {latency['count']} changes: from entering the store to the frame that carries it "
        "(its pulses reach the servos within that 20 ms frame)"
    )
    return {
        "clients": args.clients,
        "window_s": wall,
        "rtf": rtf,
        "rtf_window_min": min(windows),
        "rtf_window_max": max(windows),
        "frames_dropped": state1["frames_dropped"] - state0["frames_dropped"],
        "page_scope_frames_per_s": page_fps,
        "page_frames_advanced": [n for n, _r in numbered],
        "page_frames_received": [r for _n, r in numbered],
        "server_cpu_pct_of_one_core": 100 * (cpu1 - cpu0) / wall,
        "firmware_busy_cycles_max": (state1.get("firmware") or {}).get("busy_cycles_max"),
        "change_latency_frames": {
            "median": latency["median"],
            "max": latency["max"],
            "count": latency["count"],
        },
    }


if __name__ == "__main__":
    main()
