"""Warp kernels that feed a segment's planned controls to `d.ctrl` step by step, made on
first use (Warp is the `gpu` extra's; no `from __future__ import annotations` here: Warp
reads the kernels' annotations as types)."""

import functools
from types import SimpleNamespace


@functools.cache
def control_kernels() -> SimpleNamespace:
    """`set_ctrl` copies row `cursor[0]` of the segment's controls (worlds, steps, nu) into
    ctrl (worlds, nu); `advance`, launched after it in stream order, moves the cursor on. A
    captured frame replays both per step, so it needs no offset of its own. `keep_row`, after
    the step, keeps its sensordata in row `cursor[0] - 1` of the segment's rows (worlds, steps,
    nsensordata), for the closed loop's sensors."""
    import warp as wp

    @wp.kernel
    def set_ctrl(
        control: wp.array3d(dtype=float),
        cursor: wp.array(dtype=int),
        ctrl: wp.array2d(dtype=float),
    ):
        world, actuator = wp.tid()
        ctrl[world, actuator] = control[world, cursor[0], actuator]

    @wp.kernel
    def advance(cursor: wp.array(dtype=int)):
        cursor[0] = cursor[0] + 1

    @wp.kernel
    def keep_row(
        sensordata: wp.array2d(dtype=float),
        cursor: wp.array(dtype=int),
        rows: wp.array3d(dtype=float),
    ):
        world, i = wp.tid()
        rows[world, cursor[0] - 1, i] = sensordata[world, i]

    return SimpleNamespace(set_ctrl=set_ctrl, advance=advance, keep_row=keep_row)
