"""The soles' force sensors as MuJoCo's touch sensors read them, computed from a step's contacts
only when read (docs/DESIGN.md §15): one run's (`fsr_forces`) or many runs' at once in whole
arrays (`fsr_forces_of`, a lane's group), to the bit of the touch sensors."""

from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import mujoco
import numpy as np
from numpy.typing import NDArray

from app.robots.model import RobotModel


def fsr_forces(robot: RobotModel, data: mujoco.MjData) -> NDArray[np.float64]:
    """(2, 4) each force sensor's reading from `data` after a physics step: what a MuJoCo touch
    sensor on its zone site reads, by MuJoCo's own rule -- the normal forces of the contacts of
    the step that touch the foot, each counted where the ray from its point along its normal
    (away from the foot) meets the zone. Computed only when read, so a run that reads no sensor
    pays nothing for them (a touch sensor in the model costs every step): `fsr_forces_of` of
    one run."""
    return fsr_forces_of([robot], [data])[0]


def fsr_forces_of(
    robots: Sequence[RobotModel], datas: Sequence[mujoco.MjData]
) -> NDArray[np.float64]:
    """`fsr_forces` of K runs of one robot description (each its (varied) robot and its MjData
    after a step), (K, 2, 4), in whole arrays over all their contacts: MuJoCo's contact force
    (`mj_contactForce`: a pyramid's normal force is the sum of its edges' forces, in their
    order) and its ray-box test (`mju_rayGeom`'s, face by face), each sensor's forces summed in
    contact order as the touch sensor sums them."""
    model = robots[0].model
    out = np.zeros((len(datas), 2, 4))
    runs, geoms, points, normals, normal_n, ok = _contacts(model, datas)
    if not ok.any():
        return out
    bodies = np.where(geoms >= 0, model.geom_bodyid[np.maximum(geoms, 0)], -1)
    # every (contact, foot) pair where the contact touches the foot, foot by foot
    pairs = [
        (np.flatnonzero(ok & ((bodies[:, 0] == body) | (bodies[:, 1] == body))), foot, body)
        for foot, body in enumerate(robots[0].foot_ids)
    ]
    contact = np.concatenate([at for at, _foot, _body in pairs])
    if not len(contact):
        return out
    foot = np.concatenate([np.full(len(at), f) for at, f, _body in pairs])
    second = np.concatenate([bodies[at, 1] == body for at, _foot, body in pairs])
    ray = _unit(normals[contact] * normal_n[contact, None])
    ray = np.where(second[:, None], -ray, ray)  # the normal runs from geom 1 to 2: away from it
    zone = np.asarray(robots[0].fsr_sites)[foot]  # (n, 4)
    run = runs[contact]
    # every run's sites, (K * sites, 3) and (K * sites, 9); each contact's zones' rows in them
    site_pos = np.array([data.site_xpos for data in datas]).reshape(-1, 3)
    site_mat = np.array([data.site_xmat for data in datas]).reshape(-1, 9)
    rows = run[:, None] * model.nsite + zone
    hit = _ray_hits_box(
        site_pos.take(rows, axis=0), site_mat.take(rows, axis=0), model.site_size[zone],
        points[contact, None, :], ray[:, None, :],
    )  # fmt: skip
    at, corner = np.nonzero(hit)  # a sensor's forces in contact order, as the touch sums them
    np.add.at(out, (run[at], foot[at], corner), normal_n[contact[at]])
    return out


def _contacts(model: mujoco.MjModel, datas: Sequence[mujoco.MjData]) -> tuple[NDArray, ...]:
    """Every run's contacts of its last step, run by run in MuJoCo's order: the run of each,
    its geoms (n, 2), point (n, 3), normal (n, 3), normal force (n,) as `mj_contactForce` gives
    it, and whether it counts (in the constraint solver, normal force > 0)."""
    counts = np.array([data.ncon for data in datas])
    touched = np.flatnonzero(counts)
    lists = [datas[int(k)].contact for k in touched]
    geoms = np.concatenate([c.geom for c in lists]) if lists else np.zeros((0, 2), int)
    if not len(geoms):
        return (
            np.zeros(0, int),
            geoms,
            np.zeros((0, 3)),
            np.zeros((0, 3)),
            np.zeros(0),
            np.zeros(0, bool),
        )
    points = np.concatenate([c.pos for c in lists])
    normals = np.concatenate([c.frame for c in lists])[:, :3]
    adr, dim = (
        np.concatenate([c.efc_address for c in lists]),
        np.concatenate([c.dim for c in lists]),
    )
    forces = [datas[int(k)].efc_force for k in touched]
    first = np.repeat(np.cumsum([0] + [len(f) for f in forces[:-1]]), counts[touched])
    pyramidal = model.opt.cone == mujoco.mjtCone.mjCONE_PYRAMIDAL
    edges = np.where(pyramidal & (dim > 1), 2 * (dim - 1), 1)  # 1: elliptic, frictionless
    taken = np.arange(edges.max())
    counted = (adr[:, None] >= 0) & (taken < edges[:, None])
    efc = np.concatenate(forces)
    pyramid = np.where(
        counted, efc[np.where(counted, first[:, None] + adr[:, None] + taken, 0)], 0.0
    )
    normal_n = np.zeros(len(adr))
    for edge in range(pyramid.shape[1]):  # force[0] += pyramid[i], in order, from 0
        normal_n = normal_n + pyramid[:, edge]
    runs = np.repeat(touched, counts[touched])
    return runs, geoms, points, normals, normal_n, (adr >= 0) & (normal_n > 0.0)


def _unit(vectors: NDArray[np.float64]) -> NDArray[np.float64]:
    """Each row (n, 3) scaled to length 1 as `mju_normalize3` does it (x: (1, 0, 0))."""
    x, y, z = vectors[:, 0], vectors[:, 1], vectors[:, 2]
    norm = np.sqrt(x * x + y * y + z * z)
    small = norm < mujoco.mjMINVAL
    scaled = vectors * (1.0 / np.where(small, 1.0, norm))[:, None]
    return np.where(small[:, None], np.array([1.0, 0.0, 0.0]), scaled)


#: the box's six faces as MuJoCo's ray-box test takes them, axis by axis, the near side first:
#: each face's axis, its side, and the axis's two others
_FACE_AXIS = np.array([0, 0, 1, 1, 2, 2])
_FACE_SIDE = np.array([-1.0, 1.0, -1.0, 1.0, -1.0, 1.0])
_FACE_A, _FACE_B = np.array([1, 1, 0, 0, 0, 0]), np.array([2, 2, 2, 2, 1, 1])


def _ray_hits_box(
    pos: NDArray[np.float64],
    mat: NDArray[np.float64],
    size: NDArray[np.float64],
    point: NDArray[np.float64],
    ray: NDArray[np.float64],
) -> NDArray[np.bool_]:
    """Whether each ray from `point` along `ray` meets each box (centre `pos` (..., 3),
    orientation `mat` (..., 9) row-major, half sizes `size` (..., 3)), face by face as MuJoCo's
    ray-box test: a face hit at a distance >= 0 within its rectangle (all six faces at once
    along a last axis, each with the arithmetic of its own test)."""
    frame = mat.reshape(*mat.shape[:-1], 3, 3)
    dif = point - pos
    # three arrays' sum: an array (sum's type allows its start, 0)
    local_point = cast(NDArray, sum(frame[..., j, :] * dif[..., j, None] for j in range(3)))
    local_ray = cast(NDArray, sum(frame[..., j, :] * ray[..., j, None] for j in range(3)))
    ray_n = local_ray[..., _FACE_AXIS]
    with np.errstate(divide="ignore", invalid="ignore"):
        x = (_FACE_SIDE * size[..., _FACE_AXIS] - local_point[..., _FACE_AXIS]) / ray_n
        p0 = local_point[..., _FACE_A] + x * local_ray[..., _FACE_A]
        p1 = local_point[..., _FACE_B] + x * local_ray[..., _FACE_B]
        inside = (np.abs(p0) <= size[..., _FACE_A]) & (np.abs(p1) <= size[..., _FACE_B])
        hit = (np.abs(ray_n) > mujoco.mjMINVAL) & (x >= 0) & inside
    return hit.any(axis=-1)
