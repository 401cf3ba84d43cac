"""The legs of a CAD biped, found by geometry (docs/DESIGN.md §16): the two chains from the
root whose ends lie farthest, together, from the centre of mass, each of six hinges; a closed
chain or a third leg refused (`ImportRefused`, naming the body or joint)."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from app.robots.cad_geometry import (
    Frame,
    Vec,
    chain_path,
    collides,
    element_name,
    geom_points,
    joint_name,
    subtree_of,
    tree_children,
)
from app.robots.description_parts import LEG_JOINTS

#: a third chain whose end comes this close (as a share of the leg) to the soles' level is a leg
THIRD_LEG_FRACTION = 0.1


#: the two legs are mirror images when each length agrees within 3 mm or 3 %, the larger
MIRROR_TOLERANCE_M = 0.003
MIRROR_TOLERANCE_FRACTION = 0.03


class ImportRefused(ValueError):
    """A file the gait cannot drive: the message names the joint (or body) and the number."""


@dataclass
class Leg:
    end: int  # the chain's last body
    joints: list[int]  # hinge ids, trunk first
    foot: int = -1  # the body of the last hinge
    side: str = ""


def body_name(model: mujoco.MjModel, b: int) -> str:
    return element_name(model, mujoco.mjtObj.mjOBJ_BODY, b)


_named = element_name


# --- the legs ---------------------------------------------------------------------------------


def find_legs(model: mujoco.MjModel, data: mujoco.MjData, root: int, frame: Frame) -> list[Leg]:
    """The two chains whose ends lie farthest, together, from the centre of mass: the legs."""
    children = tree_children(model)
    subtree = {root}
    stack = [root]
    while stack:
        b = stack.pop()
        subtree.update(children[b])
        stack.extend(children[b])
    ends = [b for b in subtree if b != root and not children[b]]
    if len(ends) < 2:
        raise ImportRefused(
            f"the robot has {len(ends)} limb end(s) below its root body; a biped has two legs"
        )
    com = frame.point(data.subtree_com[root])
    where = {b: frame.point(data.xpos[b]) for b in ends}
    best, pair = -1.0, (ends[0], ends[1])
    for i, a in enumerate(ends):
        for b in ends[i + 1 :]:
            if branch_of(model, root, a, b) is None:
                continue
            reach = float(np.linalg.norm((where[a] + where[b]) / 2 - com))
            if reach > best:
                best, pair = reach, (a, b)
    legs = []
    branch = branch_of(model, root, *pair)
    for end in pair:
        bodies = chain_path(model, branch if branch is not None else root, end)
        hinges = []
        for body in bodies:
            for j in range(
                model.body_jntadr[body], model.body_jntadr[body] + model.body_jntnum[body]
            ):
                if model.jnt_type[j] != mujoco.mjtJoint.mjJNT_HINGE:
                    kind = {1: "ball", 2: "slide", 0: "free"}.get(int(model.jnt_type[j]), "other")
                    raise ImportRefused(
                        f"joint {joint_name(model, j)!r} in the leg ending at body "
                        f"{body_name(model, end)!r} is a {kind} joint; "
                        "the gait drives hinges (a servo each)"
                    )
                hinges.append(j)
        if len(hinges) != len(LEG_JOINTS):
            names = ", ".join(joint_name(model, j) for j in hinges) or "none"
            raise ImportRefused(
                f"the leg ending at body {body_name(model, end)!r} has "
                f"{len(hinges)} hinge joints ({names}); the gait drives {len(LEG_JOINTS)} a leg: "
                "hip yaw, hip roll, hip pitch, knee, ankle pitch, ankle roll"
            )
        legs.append(Leg(end=end, joints=hinges, foot=int(model.jnt_bodyid[hinges[-1]])))
    return legs


def branch_of(model: mujoco.MjModel, root: int, a: int, b: int) -> int | None:
    """The body where the chains to `a` and `b` part (None: one lies on the other's chain)."""
    path_a, path_b = [root, *chain_path(model, root, a)], [root, *chain_path(model, root, b)]
    common = 0
    while common < min(len(path_a), len(path_b)) and path_a[common] == path_b[common]:
        common += 1
    if common in (len(path_a), len(path_b)):
        return None
    return path_a[common - 1]


def foot_points(model: mujoco.MjModel, data: mujoco.MjData, foot: int, frame: Frame) -> Vec:
    """The foot's collision geometry as points in the root frame; ImportRefused if it has none."""
    geoms = [
        g
        for b in subtree_of(model, foot)
        for g in range(model.ngeom)
        if model.geom_bodyid[g] == b and collides(model, g)
    ]
    if not geoms:
        raise ImportRefused(
            f"the foot body {body_name(model, foot)!r} has no collision "
            "geometry: nothing for the robot to stand on (give the foot a collision geom)"
        )
    return np.concatenate([frame.point(geom_points(model, data, g)) for g in geoms])


def check_closed_chains(model: mujoco.MjModel, legs: list[Leg]) -> None:
    leg_bodies = {
        b for leg in legs for b in subtree_of(model, int(model.jnt_bodyid[leg.joints[0]]))
    }
    for e in range(model.neq):
        obj = mujoco.mjtObj.mjOBJ_JOINT if model.eq_type[e] == mujoco.mjtEq.mjEQ_JOINT else None
        ids = {int(model.eq_obj1id[e]), int(model.eq_obj2id[e])}
        bodies = {int(model.jnt_bodyid[i]) for i in ids if i >= 0} if obj else ids
        if bodies & leg_bodies:
            raise ImportRefused(
                f"equality constraint {_named(model, mujoco.mjtObj.mjOBJ_EQUALITY, e)!r} closes a "
                "chain through a leg; the gait drives open chains, a servo on each hinge"
            )
    for t in range(model.ntendon):
        raise ImportRefused(
            f"tendon {element_name(model, mujoco.mjtObj.mjOBJ_TENDON, t)!r}: the gait drives open "
            "chains, a servo on each hinge (remove tendons and linkages from the file)"
        )


def check_third_leg(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    frame: Frame,
    root: int,
    legs: list[Leg],
    up: Vec,
    soles: list[Vec],
    geometry: dict[str, float],
) -> None:
    ends = {leg.end for leg in legs}
    children = tree_children(model)
    floor = float(np.mean([s @ up for s in soles]))
    leg_m = geometry["thigh_m"] + geometry["shank_m"]
    for b in subtree_of(model, root):
        if b in ends or children[b]:
            continue
        geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] == b and collides(model, g)]
        if not geoms:
            continue
        low = min(float((frame.point(geom_points(model, data, g)) @ up).min()) for g in geoms)
        if low - floor < THIRD_LEG_FRACTION * leg_m:
            raise ImportRefused(
                f"body {body_name(model, b)!r} reaches down to "
                f"{1000 * (low - floor):.0f} mm above the soles: a third leg; the gait walks two"
            )


def check_mirror(lengths: dict[str, list[float]], hips: list[Vec], to_trunk: Vec) -> None:
    for what, (a, b) in lengths.items():
        allowed = max(MIRROR_TOLERANCE_M, MIRROR_TOLERANCE_FRACTION * max(a, b))
        if abs(a - b) > allowed:
            raise ImportRefused(
                f"the legs are no mirror images: the left {what} is {1000 * a:.1f} mm, the right "
                f"{1000 * b:.1f} mm (at most {1000 * allowed:.1f} mm apart); the gait walks both "
                "legs with one geometry"
            )
    left, right = to_trunk @ hips[0], to_trunk @ hips[1]
    for axis in (0, 2):
        gap = abs(float(left[axis] - right[axis]))
        if gap > MIRROR_TOLERANCE_M:
            raise ImportRefused(
                f"the legs are no mirror images: the hips lie {1000 * gap:.1f} mm apart "
                f"{'forward' if axis == 0 else 'in height'} (at most "
                f"{1000 * MIRROR_TOLERANCE_M:g} mm)"
            )


# --- what the description carries ------------------------------------------------------------


def link_masses(model: mujoco.MjModel, leg: Leg) -> dict[str, float]:
    """Each link's mass on one leg (what each hinge moves that the next one does not) and the
    trunk's (the rest)."""
    links = ("hip_yaw", "hip_roll", "thigh", "shank", "ankle", "foot")
    bodies = [int(model.jnt_bodyid[j]) for j in leg.joints]
    masses = {}
    for k, link in enumerate(links):
        moved = set(subtree_of(model, bodies[k]))
        below = set(subtree_of(model, bodies[k + 1])) if k + 1 < len(bodies) else set()
        masses[link] = float(sum(model.body_mass[b] for b in moved - below))
    root = int(model.body_rootid[bodies[0]])
    masses["trunk"] = float(model.body_subtreemass[root]) - 2 * sum(masses[link] for link in links)
    return masses
