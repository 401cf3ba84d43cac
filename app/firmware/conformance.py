"""Emulated firmware against the Python model, frame by frame (docs/DESIGN.md §5): pin edges
against `hardware.frame_edges` of the frame loop's `plan_frames`, tick for tick (a falling edge one
tick off where float32 and float64 round a pulse apart is counted), angles within half a Timer
tick's worth of angle (`ANGLE_TOLERANCE_RAD`)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from app.firmware.build import build_firmware, wiring
from app.firmware.emulator import (
    CYCLES_PER_TICK,
    FRAME_CYCLES,
    LINE_NAMES,
    Edges,
    Mcu,
    read_active_plan,
)
from app.firmware.vcd import write_vcd
from app.robots.model import RobotModel
from app.sim.frame_loop import HardwareSetup
from app.sim.planning import FRAME_S, START_PHASE_RAD, plan_frames
from gait import ARTRO_LEG, GaitParams, LegGeometry, Motion, pi_cut
from hardware import (
    CHANNELS,
    FRAME_TICKS,
    SLOT_TICKS,
    TICK_US,
    US_PER_DEG,
    FrameEdges,
    frame_edges,
)

#: the firmware's float32 joint angles against the model's float64 ones: within half a Timer tick
#: of pulse (0.25 µs at 10 µs per degree, 4.4e-4 rad), below what a pulse can show. Float32's
#: error grows where the leg interface's arccos is steep (a leg near straight): a random set
#: reached 1.7e-4 rad with all 3012 of its pulses tick-exact, past the 1e-4 once asked.
ANGLE_TOLERANCE_RAD = math.radians(TICK_US / 2 / US_PER_DEG)
_DUMP_TICK = 100  # read the frame's plan this far into the frame (after the latch, at tick 0)


@dataclass(frozen=True)
class ModelFrames:
    phase: NDArray[np.float64]  # (n,)
    angles: NDArray[np.float64]  # (n, 12)
    ocr: NDArray[np.int32]  # (n, 6, 8)


def model_frames(
    doc: dict[str, Any],
    n_frames: int,
    hardware: HardwareSetup | None = None,
    *,
    changes: Sequence[tuple[int, dict[str, Any]]] = (),
    geometry: LegGeometry = ARTRO_LEG,
) -> ModelFrames:
    """The Python frame loop's first n frames for a parameter-set document.

    `changes` lists (frame, document) switches, as `FrameLoop.set_gait` between frames: the
    new set's first frame keeps the phase step of the old one, as the loop's walking clock does,
    and its motion is ramped to from the old one's (`ramp` group).
    """
    hardware = hardware or HardwareSetup()
    segments = [(0, doc), *sorted(changes, key=lambda change: change[0])]
    phase, parts, motion_now = START_PHASE_RAD, [], None
    ends = [start for start, _ in segments[1:]] + [n_frames]
    for (start, seg_doc), end in zip(segments, ends, strict=True):
        if end <= start:
            continue
        params = GaitParams.from_dict(seg_doc["gait"])
        motion = Motion(**seg_doc["motion"])
        plan = plan_frames(
            params,
            motion,
            hardware,
            phase,
            end - start,
            10,
            0.002,
            motion_now=motion_now,
            geometry=geometry,
        )
        motion_now = plan.motions[-1]  # a new set's motion is ramped to from here
        parts.append(plan)
        step = 2.0 * math.pi * params.clock.freq_hz * FRAME_S
        phase = float(pi_cut(plan.phase[-1] + step))
    return ModelFrames(
        np.concatenate([p.phase for p in parts]),
        np.concatenate([p.angles for p in parts]),
        np.concatenate([p.ocr for p in parts]),
    )


def _per_line(edges: Edges, t0_cycle: int) -> list[tuple[NDArray[np.int64], NDArray[np.int64]]]:
    ticks = (edges.cycle.astype(np.int64) - t0_cycle) // CYCLES_PER_TICK
    per_line = []
    for line in range(len(LINE_NAMES)):
        mask = edges.line == line
        per_line.append((ticks[mask], edges.level[mask].astype(np.int64)))
    return per_line


def _frame(per_line: list[tuple[NDArray[np.int64], NDArray[np.int64]]], k: int) -> FrameEdges:
    start, end = k * FRAME_TICKS, (k + 1) * FRAME_TICKS
    initial, lines = [], []
    for line_ticks, levels in per_line:
        before = np.flatnonzero(line_ticks <= start)
        initial.append(int(levels[before[-1]]) if len(before) else 0)
        inside = (line_ticks > start) & (line_ticks < end)
        lines.append(
            tuple(
                (int(t - start), int(v))
                for t, v in zip(line_ticks[inside], levels[inside], strict=True)
            )
        )
    return FrameEdges(LINE_NAMES, tuple(initial), tuple(lines))


def split_frames(edges: Edges, t0_cycle: int, n_frames: int) -> list[FrameEdges]:
    """Cut recorded edges into FrameEdges of frames 0..n-1 (ticks from each frame's start)."""
    per_line = _per_line(edges, t0_cycle)
    return [_frame(per_line, k) for k in range(n_frames)]


def frame_edges_of(edges: Edges, t0_cycle: int, k: int) -> FrameEdges:
    """Frame k's FrameEdges from recorded edges that include at least its own and the level
    before it (a line's level before the first edge given counts as 0)."""
    return _frame(_per_line(edges, t0_cycle), k)


@dataclass
class Comparison:
    """How the emulated pins and angles compare with the model over some frames."""

    frames: int = 0
    pulses: int = 0  # pulses (falling edges on the TDM lines) compared
    exact: int = 0
    one_tick: int = 0
    mismatches: list[str] = field(default_factory=list)
    select_outside_guard: int = 0  # select-line edges not at the guard's change tick
    max_angle_error_rad: float = 0.0
    busy_cycles: list[int] = field(default_factory=list)  # per frame, CPU not asleep
    edges: Edges | None = None  # the recorded edges, if asked to keep them

    @property
    def ok(self) -> bool:
        return not self.failures()

    def failures(self) -> list[str]:
        """What differs from the model beyond its tolerance, in words ([] when it matches)."""
        said = []
        if self.mismatches:
            said.append(
                f"pulses that differ from the model's: {len(self.mismatches)} (the first: "
                f"{self.mismatches[0]})"
            )
        if self.select_outside_guard:
            said.append(
                f"select-line edges outside the guard's change tick: {self.select_outside_guard}"
            )
        if self.max_angle_error_rad > ANGLE_TOLERANCE_RAD:
            said.append(
                f"the angles differ by up to {self.max_angle_error_rad:.3g} rad (tolerance "
                f"{ANGLE_TOLERANCE_RAD:g})"
            )
        return said

    def summary(self) -> dict[str, Any]:
        return {
            "ok": self.ok,
            "frames": self.frames,
            "pulses_compared": self.pulses,
            "exact": self.exact,
            "one_tick": self.one_tick,
            "mismatches": len(self.mismatches),
            "select_outside_guard": self.select_outside_guard,
            "max_angle_error_rad": self.max_angle_error_rad,
            "cycles_per_frame_max": max(self.busy_cycles, default=0),
            "cycles_per_frame_mean": float(np.mean(self.busy_cycles)) if self.busy_cycles else 0,
        }


def compare_frame(
    got: FrameEdges, want: FrameEdges, frame: int, result: Comparison, select_tick: int
) -> None:
    """Add one frame's comparison to `result`."""
    for name in LINE_NAMES:
        got_initial, got_edges = got.line(name)
        want_initial, want_edges = want.line(name)
        is_channel = name in CHANNELS
        if is_channel:
            result.pulses += sum(1 for _, level in want_edges if level == 0)
        else:
            result.select_outside_guard += sum(
                1 for tick, _ in got_edges if tick % SLOT_TICKS != select_tick
            )
        if got_initial != want_initial or len(got_edges) != len(want_edges):
            result.mismatches.append(
                f"frame {frame} {name}: got {got_initial} {got_edges}, want {want_initial} "
                f"{want_edges}"
            )
            continue
        for (t_got, v_got), (t_want, v_want) in zip(got_edges, want_edges, strict=True):
            if v_got != v_want:
                result.mismatches.append(f"frame {frame} {name}: level {v_got} != {v_want}")
            elif t_got == t_want:
                result.exact += is_channel and v_want == 0
            elif is_channel and v_want == 0 and abs(t_got - t_want) == 1:
                result.one_tick += 1
            else:
                result.mismatches.append(
                    f"frame {frame} {name}: edge to {v_want} at tick {t_got}, model {t_want}"
                )


def run_comparison(
    mcu: Mcu,
    model: ModelFrames,
    hardware: HardwareSetup | None = None,
    *,
    first_frame: int = 0,
    keep_edges: bool = False,
) -> Comparison:
    """Run the emulator through frames first_frame..len(model)-1 and compare with the model.

    The edges recorded before `first_frame` are dropped; angles are read from the firmware's
    plan of each frame not yet begun (so the run goes frame by frame).
    """
    hardware = hardware or HardwareSetup()
    n_frames = len(model.phase)
    result = Comparison()
    busy_before = None
    begun = (mcu.cycle - mcu.t0_cycle) // FRAME_CYCLES + 1  # frames whose plans we missed
    for k in range(max(first_frame, begun), n_frames):
        mcu.run_to_frame(k, _DUMP_TICK)
        plan = read_active_plan(mcu)
        if plan.frame != k:
            result.mismatches.append(f"frame {k}: the firmware outputs its plan of {plan.frame}")
        error = float(np.max(np.abs(plan.angles.astype(np.float64) - model.angles[k])))
        result.max_angle_error_rad = max(result.max_angle_error_rad, error)
        busy = mcu.busy_cycles
        if busy_before is not None:
            result.busy_cycles.append(busy - busy_before)
        busy_before = busy
    mcu.run_to_frame(n_frames)
    recorded = mcu.take_edges()
    if keep_edges:
        result.edges = recorded
    edges = split_frames(recorded, mcu.t0_cycle, n_frames)
    for k in range(first_frame, n_frames):
        want = frame_edges(model.ocr[k], hardware.tdm)
        compare_frame(edges[k], want, k, result, hardware.tdm.select_change_ticks)
    result.frames = n_frames - first_frame
    return result


def check_firmware(
    doc: dict[str, Any], frames: int, vcd: str | None = None, robot: RobotModel | None = None
) -> dict[str, Any]:
    """Emulate `frames` frames of the firmware built for `doc` on `robot` (default: artro);
    the comparison as a dict."""
    robot = robot or RobotModel.load()
    build = build_firmware(doc, **wiring(robot))
    model = model_frames(doc, frames, robot.hardware(), geometry=robot.geometry)
    with Mcu(build.elf) as mcu:
        result = run_comparison(mcu, model, robot.hardware(), keep_edges=vcd is not None)
        if vcd:
            assert result.edges is not None  # keep_edges
            write_vcd(vcd, result.edges, mcu.t0_cycle, comment=f"parameter set {doc['name']}")
        lag = mcu.timer3_lag_cycles
    return {
        **result.summary(),
        "flash_bytes": build.flash_bytes,
        "sram_bytes": build.sram_bytes,
        "timer3_start_lag_cycles": lag,
        "robot": robot.name,
        "failures": result.failures(),
    }
