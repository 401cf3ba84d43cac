"""Benchmark: what the dashboard's session features cost the simulation thread per 20 ms frame.

Times, on one core, a frame of the live robot (`FrameLoop.step_frame`), a frame of the A/B ghost
(`Ghost.step`: a second robot), the recorder's write of a frame (`Recorder.add`), a copy of the
60 s ring (`Recorder.recording`, what an export or a replay takes), and the memory of the ring.

    python bench/bench_session.py [--frames 500] [--json PATH]

Writes the figures to bench/results/<bench>.json, or to --json PATH (bench/results.py).
"""

from __future__ import annotations

import argparse
import time

import results

from app.params.presets import builtin_presets
from app.server.recording.recorder import Recorder
from app.server.sim.ghost import Ghost
from app.sim.frame_loop import FrameLoop
from app.sim.planning import FRAME_S
from gait import Motion


def per_frame_ms(step, frames: int) -> float:
    start = time.perf_counter()
    for _ in range(frames):
        step()
    return 1000.0 * (time.perf_counter() - start) / frames


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=500)
    args = results.parse_args(parser)
    presets = builtin_presets()
    live = FrameLoop(params=presets["tuned"].gait, motion=Motion(a_p=0.07))
    ghost = Ghost(live, presets["paper"].gait, "preset paper")
    recorder = Recorder(live.model.nq, "artro")
    record = live.step_frame()

    live_ms = per_frame_ms(live.step_frame, args.frames)
    ghost_ms = per_frame_ms(lambda: ghost.step(live, live.motion, live.phase), args.frames)
    add_ms = per_frame_ms(lambda: recorder.add(record, live.data.qpos, 1), recorder.capacity)
    copy_ms = per_frame_ms(recorder.recording, 20)
    ring = recorder.recording()
    columns = ("frame", "t_s", "sim_t_s", "phase", "qpos", "ocr", "version", "drive")
    ring_bytes = sum(getattr(ring, name).nbytes for name in columns)
    frame_ms = 1000.0 * FRAME_S
    print(f"live robot frame    : {live_ms:.3f} ms ({100 * live_ms / frame_ms:.1f} % of 20 ms)")
    print(f"A/B ghost frame     : {ghost_ms:.3f} ms ({100 * ghost_ms / frame_ms:.1f} % of 20 ms)")
    print(f"recorder, per frame : {1000 * add_ms:.1f} µs")
    print(f"copy of the ring    : {copy_ms:.2f} ms ({len(ring)} frames, {ring_bytes / 1e6:.2f} MB)")
    figures = {
        "frame_ms": frame_ms,
        "live_frame_ms": live_ms,
        "ghost_frame_ms": ghost_ms,
        "recorder_us_per_frame": 1000 * add_ms,
        "ring_copy_ms": copy_ms,
        "ring_frames": len(ring),
        "ring_mb": ring_bytes / 1e6,
    }
    headline = {
        "live robot frame (ms of 20)": live_ms,
        "A/B ghost frame (ms of 20)": ghost_ms,
        "recorder, per frame (µs)": 1000 * add_ms,
    }
    results.write("bench_session", args, figures, headline)


if __name__ == "__main__":
    main()
