"""One MuJoCo Warp model for the worlds of a batch, each world with its own robot's values
(docs/GPU.md "What it batches"): the fields in which the worlds' models differ, one row per
world; a differing field MuJoCo Warp cannot hold per world refuses the call (ExecutorError)."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import mujoco
import numpy as np

from app.evaluation._api import ExecutorError

#: the leading dimension of a `mujoco_warp.Model` field that may hold one row per world
_BATCHED_MARK = "*"


def _flat(obj: Any, prefix: str = "") -> dict[str, tuple[Any, bool]]:
    """Every field of a `mujoco_warp.Model` (nested dataclasses such as `opt` as `opt.name`):
    its host value (arrays as numpy) and whether MuJoCo Warp can hold it per world."""
    import warp as wp

    out: dict[str, tuple[Any, bool]] = {}
    for field in dataclasses.fields(obj):
        value = getattr(obj, field.name)
        name = prefix + field.name
        if dataclasses.is_dataclass(value):
            out |= _flat(value, name + ".")
            continue
        shape: tuple[Any, ...] = getattr(field.type, "shape", ())
        per_world = bool(shape) and shape[0] == _BATCHED_MARK
        if isinstance(value, wp.array):
            out[name] = (value.numpy(), per_world)
        elif isinstance(value, (tuple, list)):
            items = [v.numpy() if isinstance(v, wp.array) else v for v in value]
            out[name] = (items, False)
        else:
            out[name] = (value, False)
    return out


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        return a.shape == b.shape and bool(np.array_equal(a, b, equal_nan=a.dtype.kind == "f"))
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    return bool(a == b)


def _mj_value(model: mujoco.MjModel, name: str) -> Any:
    """The MjModel field of a `mujoco_warp.Model` field's name (`opt.gravity` as
    `model.opt.gravity`), or None where MjModel has none of that name (a derived field)."""
    owner: Any = model
    *path, leaf = name.split(".")
    for part in path:
        owner = getattr(owner, part, None)
    value = getattr(owner, leaf, None)
    return value if isinstance(value, (np.ndarray, int, float)) else None


def _moved(named: dict[str, Any], models: Sequence[mujoco.MjModel]) -> list[set[str]]:
    """For each of `models`, the names of `named` (MjModel fields and the first model's
    values) in which it differs from those values (`_same`'s rule: NaN equals NaN), each field
    compared for all the models at once."""
    moved: list[set[str]] = [set() for _ in models]
    for name, value in named.items():
        first = np.asarray(value)
        rows = [np.asarray(_mj_value(m, name)) for m in models]
        if any(row.shape != first.shape for row in rows):  # not one array: one by one
            differ = [not _same(value, row) for row in rows]
        else:
            stacked = np.stack(rows)  # the caller passes at least one model
            equal = stacked == first
            if first.dtype.kind == "f":
                equal |= np.isnan(stacked) & np.isnan(first)
            differ = list(~equal.reshape(len(rows), -1).all(axis=1))
        for i in np.flatnonzero(differ):
            moved[i].add(name)
    return moved


def _differing(flats: Sequence[dict[str, tuple[Any, bool]]]) -> list[str]:
    """The fields whose host values are not the same in all of `flats` (put models)."""
    first = flats[0]
    return [name for name in first if any(not _same(first[name][0], f[name][0]) for f in flats)]


def _refuse(first: dict[str, tuple[Any, bool]], differ: list[str]) -> None:
    refused = [name for name in differ if not first[name][1]]
    if refused:
        raise ExecutorError(
            "the runs' robots differ in "
            + ", ".join(refused)
            + ", which MuJoCo Warp cannot hold per world: run these jobs with --backend cpu "
            "(docs/GPU.md)"
        )


def per_world_fields(models: Sequence[mujoco.MjModel]) -> dict[str, np.ndarray]:
    """The `mujoco_warp.Model` fields in which `models` (one per world, the same object for
    worlds of one variation) differ, each as (worlds, ...) host values, one row per world.

    A variation is a copy of the compiled model with values changed (`vary_model`: friction,
    masses and what `mj_setConst` derives from them, servo gains, force ranges, damping,
    friction loss, gravity). MuJoCo Warp holds a field per world when its leading dimension is
    `*` (kernels read row `worldid % rows`). A field that differs but has no per-world form (a
    count, a type, a solver setting) raises ExecutorError naming it: no variation of today
    changes one (`tests/evaluation/test_warp_executor.py`).

    Putting every distinct model on the device to compare takes ~50 ms a model (a 900-variation
    study: 45 s), so two are put: the first world's and the one differing from it in the most
    MjModel fields. Where every field in which those two differ as put models is an MjModel
    field of the same name, differing in the same way, and no model differs from the first in
    another MjModel field, the values are the MjModels' own; otherwise every distinct model is
    put and compared (`_per_world_fields_put`)."""
    import mujoco_warp as mjw
    import warp as wp

    firsts = list({id(m): m for m in models}.values())
    if len(firsts) == 1:
        return {}
    with wp.ScopedDevice("cpu"):  # host copies to compare: nothing goes to the batch's device
        first = _flat(mjw.put_model(firsts[0]))
        named = {name: v for name in first if (v := _mj_value(firsts[0], name)) is not None}
        moved = _moved(named, firsts[1:])
        probe = max(range(len(moved)), key=lambda i: len(moved[i]))
        pair = [first, _flat(mjw.put_model(firsts[probe + 1]))]
    differ = _differing(pair)
    if set(differ) != moved[probe] or any(not m <= moved[probe] for m in moved):
        return _per_world_fields_put(models)
    _refuse(first, differ)
    rows = _rows(models)  # read once per distinct model, then one row per world
    return {
        name: np.stack([np.asarray(_mj_value(m, name), first[name][0].dtype) for m in firsts])[rows]
        for name in differ
    }


def _rows(models: Sequence[mujoco.MjModel]) -> np.ndarray:
    """Each world's index among the distinct models, in the order they first appear."""
    distinct: dict[int, int] = {}
    return np.array([distinct.setdefault(id(m), len(distinct)) for m in models])


def _per_world_fields_put(models: Sequence[mujoco.MjModel]) -> dict[str, np.ndarray]:
    """`per_world_fields` by putting every distinct model on Warp's CPU device and comparing
    all their fields (slow; the case its shortcut does not cover)."""
    import mujoco_warp as mjw
    import warp as wp

    firsts = list({id(m): m for m in models}.values())
    with wp.ScopedDevice("cpu"):
        flats = [_flat(mjw.put_model(model)) for model in firsts]
    differ = _differing(flats)
    _refuse(flats[0], differ)
    rows = _rows(models)
    return {name: np.stack([flat[name][0][0] for flat in flats])[rows] for name in differ}


def batch_model(
    models: Sequence[mujoco.MjModel], device: Any, fields: dict[str, np.ndarray] | None = None
) -> Any:
    """A `mujoco_warp.Model` on `device` for the worlds of `models` (one per world): the first
    world's model, with every field in which the worlds differ held per world: `fields` where
    the caller read them already, else `per_world_fields(models)`. ExecutorError as
    `per_world_fields`."""
    import mujoco_warp as mjw
    import warp as wp

    if fields is None:
        fields = per_world_fields(models)
    with wp.ScopedDevice(device):
        batch = mjw.put_model(models[0])
        for name, values in fields.items():
            *path, leaf = name.split(".")
            owner = batch
            for part in path:
                owner = getattr(owner, part)
            dtype = getattr(owner, leaf).dtype
            setattr(owner, leaf, wp.array(values, dtype=dtype, device=device))
    return batch
