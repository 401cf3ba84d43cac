"""Geometry of a compiled CAD model in its root body's frame (docs/DESIGN.md §16): points on
collision geoms, hinge axes as lines and where two cross, the kinematic tree; the pieces
`app.robots.cad_mapping` finds the legs with."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

Vec = NDArray[np.float64]


@dataclass(frozen=True)
class Frame:
    """The root body's frame: world points and directions into it."""

    origin: Vec
    rotation: Vec  # root axes in world, as columns

    def point(self, p: Vec) -> Vec:
        return (np.asarray(p) - self.origin) @ self.rotation

    def direction(self, v: Vec) -> Vec:
        return np.asarray(v) @ self.rotation


def unit(v: Vec) -> Vec:
    n = float(np.linalg.norm(v))
    if n < 1e-12:
        raise ValueError("the robot has no extent: its hips and soles coincide")
    return np.asarray(v, dtype=np.float64) / n


def element_name(model: mujoco.MjModel, kind: mujoco.mjtObj, index: int) -> str:
    return mujoco.mj_id2name(model, kind, index) or f"#{index}"


def joint_name(model: mujoco.MjModel, j: int) -> str:
    return element_name(model, mujoco.mjtObj.mjOBJ_JOINT, j)


def quat_of(matrix: Vec) -> tuple[float, float, float, float]:
    """The unit quaternion of the rotation whose matrix maps root coordinates to the trunk's."""
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(matrix, dtype=np.float64).ravel())
    return (float(quat[0]), float(quat[1]), float(quat[2]), float(quat[3]))


def tree_children(model: mujoco.MjModel) -> dict[int, list[int]]:
    out: dict[int, list[int]] = {b: [] for b in range(model.nbody)}
    for b in range(1, model.nbody):
        out[int(model.body_parentid[b])].append(b)
    return out


def chain_path(model: mujoco.MjModel, root: int, body: int) -> list[int]:
    """The bodies from below `root` down to `body`, root side first."""
    path = []
    while body != root:
        path.append(body)
        body = int(model.body_parentid[body])
    return path[::-1]


def subtree_of(model: mujoco.MjModel, body: int) -> list[int]:
    children = tree_children(model)
    out, stack = [], [body]
    while stack:
        b = stack.pop()
        out.append(b)
        stack.extend(children[b])
    return out


# --- points of the geometry -------------------------------------------------------------------


def geom_points(model: mujoco.MjModel, data: mujoco.MjData, g: int) -> Vec:
    """Points on geom `g`'s surface in world coordinates (corners, vertices, rims)."""
    size = model.geom_size[g]
    kind = model.geom_type[g]
    geom = mujoco.mjtGeom
    ring = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    if kind == geom.mjGEOM_BOX:
        local = (
            np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * size
        )
    elif kind == geom.mjGEOM_MESH:
        mesh = int(model.geom_dataid[g])
        start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        local = model.mesh_vert[start : start + count].astype(np.float64)
    elif kind in (geom.mjGEOM_CAPSULE, geom.mjGEOM_CYLINDER):
        r, half = size[0], size[1]
        rim = np.stack([r * np.cos(ring), r * np.sin(ring), np.zeros_like(ring)], axis=1)
        ends = [rim + np.array([0.0, 0.0, z]) for z in (-half, half)]
        if kind == geom.mjGEOM_CAPSULE:
            ends += [np.array([[0, 0, -half - r], [0, 0, half + r]])]
        local = np.concatenate(ends)
    elif kind in (geom.mjGEOM_SPHERE, geom.mjGEOM_ELLIPSOID):
        radii = size if kind == geom.mjGEOM_ELLIPSOID else np.full(3, size[0])
        local = np.concatenate([np.diag(radii), -np.diag(radii)])
    else:
        local = np.zeros((1, 3))
    return data.geom_xpos[g] + local @ data.geom_xmat[g].reshape(3, 3).T


def collides(model: mujoco.MjModel, g: int) -> bool:
    return bool(model.geom_contype[g] or model.geom_conaffinity[g])


def lowest(points: Vec, up: Vec, band_m: float) -> Vec:
    """The centre of the sole's outline: of the points within `band_m` of the lowest."""
    height = points @ up
    sole = points[height <= height.min() + band_m]
    centre = (sole.min(axis=0) + sole.max(axis=0)) / 2
    return centre - up * (centre @ up - height.min())


def axis_line(model: mujoco.MjModel, data: mujoco.MjData, frame: Frame, j: int) -> tuple[Vec, Vec]:
    return frame.point(data.xanchor[j]), unit(frame.direction(data.xaxis[j]))


def closest(p: Vec, u: Vec, q: Vec, v: Vec) -> tuple[Vec, float]:
    """The midpoint of the shortest segment between lines p + s·u and q + t·v, and its length."""
    w = p - q
    b = u @ v
    denom = 1.0 - b * b
    if denom < 1e-9:  # parallel: the distance from q's line to p
        t = w @ v
        return (p + q + t * v) / 2, float(np.linalg.norm(w - t * v))
    s = (b * (w @ v) - (w @ u)) / denom
    t = ((w @ v) - b * (w @ u)) / denom
    a, c = p + s * u, q + t * v
    return (a + c) / 2, float(np.linalg.norm(a - c))
