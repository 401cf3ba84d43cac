"""The A/B ghost in the viser 3D view: the robot's bodies as translucent meshes under the floor's
frame, placed from the published ghost poses (docs/DESIGN.md §10)."""

from __future__ import annotations

import mujoco
import numpy as np
import viser
import viser.transforms as vtf
from mjviser.conversions import is_fixed_body, merge_geoms

GHOST_RGB = (120, 170, 255)
GHOST_OPACITY = 0.35


class GhostDrawing:
    """One translucent mesh per moving body, hidden while there is no ghost."""

    def __init__(self, server: viser.ViserServer, model: mujoco.MjModel, parent: str) -> None:
        self._server = server
        self._handles: list[tuple[int, viser.MeshHandle]] = []
        for body in range(model.nbody):
            if is_fixed_body(model, body):
                continue
            geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] == body]
            geoms = [g for g in geoms if model.geom_group[g] <= 2]  # the visible groups
            if not geoms:
                continue
            mesh = merge_geoms(model, geoms)
            handle = server.scene.add_mesh_simple(
                f"{parent}/ghost/body{body}",
                vertices=np.asarray(mesh.vertices, np.float32),
                faces=np.asarray(mesh.faces, np.uint32),
                color=GHOST_RGB,
                opacity=GHOST_OPACITY,
                visible=False,
            )
            self._handles.append((body, handle))
        self.shown = False

    def update(self, xpos: np.ndarray | None, xmat: np.ndarray | None) -> None:
        """Place the bodies at these world poses; None hides the ghost."""
        if xpos is None or xmat is None:
            if self.shown:
                for _, handle in self._handles:
                    handle.visible = False
                self.shown = False
            return
        wxyz = vtf.SO3.from_matrix(xmat.reshape(-1, 3, 3)).wxyz
        with self._server.atomic():  # one batch of messages per refresh
            for body, handle in self._handles:
                handle.position = xpos[body]
                handle.wxyz = wxyz[body]
                if not self.shown:
                    handle.visible = True
        self.shown = True
