"""What a lane of `BatchEvaluator` works with: its MjData, kept output arrays and kept
`Rollout` (decision 0027), and the check of the arrays `rollout` then takes unchecked
(docs/DESIGN.md §9)."""

from __future__ import annotations

import mujoco
import numpy as np
from mujoco import rollout

from app.evaluation._frames import STATE_SPEC, Start


def check_rollout_arrays(
    model: mujoco.MjModel,
    start: Start,
    control: np.ndarray,
    state_out: np.ndarray,
    sensor_out: np.ndarray,
) -> None:
    """What `rollout` checks on every call (it then runs unchecked): C-ordered float64 arrays of
    the model's sizes, one run, an output row per step. ValueError otherwise."""
    steps = control.shape[0]
    shapes = {
        "start state": (start.state, (mujoco.mj_stateSize(model, STATE_SPEC),)),
        "control": (control, (steps, model.nu)),
        "state output": (state_out, (1, steps, mujoco.mj_stateSize(model, STATE_SPEC))),
        "sensor output": (sensor_out, (1, steps, model.nsensordata)),
    }
    for name, (array, shape) in shapes.items():
        if array.shape != shape or array.dtype != np.float64 or not array.flags.c_contiguous:
            raise ValueError(
                f"{name} must be a C-ordered float64 array of shape {shape}, got "
                f"{array.dtype} {array.shape}"
            )


class LaneKit:
    """What one lane needs at a time: an MjData of the robot's size, kept output arrays, and a
    kept `Rollout` on the calling thread (one per call costs ~1.4 % of a run, decision 0027)."""

    def __init__(self, model: mujoco.MjModel) -> None:
        self._model = model
        self.data = mujoco.MjData(model)
        self._datas: list[mujoco.MjData] = []
        self.rollout = rollout.Rollout(nthread=0)
        self._state = np.empty((1, 0, mujoco.mj_stateSize(model, STATE_SPEC)))
        self._sensors = np.empty((1, 0, model.nsensordata))

    def datas(self, runs: int) -> list[mujoco.MjData]:
        """`runs` MjData of the robot's size (a group's: each run keeps its warm start)."""
        while len(self._datas) < runs:
            self._datas.append(mujoco.MjData(self._model))
        return self._datas[:runs]

    def output(self, steps: int) -> tuple[np.ndarray, np.ndarray]:
        """(1, steps, state size) and (1, steps, sensors) arrays, grown when a run is longer."""
        if self._state.shape[1] < steps:
            self._state = np.empty((1, steps, self._state.shape[2]))
            self._sensors = np.empty((1, steps, self._sensors.shape[2]))
        return self._state[:, :steps], self._sensors[:, :steps]
