"""The viser 3D view: the robot (mjviser), paths on the floor, the last push, and the panel's
folders (`gui_folders.py`, `parameter_folders.py`). Built once, refreshed at <= 30 Hz only when
something changed and someone watches (docs/DESIGN.md §10); sliders and store keep one
direction of truth (§11)."""

from __future__ import annotations

import copy
import logging
import threading
import time
from typing import TYPE_CHECKING, Any

import mjviser
import numpy as np
import viser

from app.server.view.gui_folders import (
    ACTUAL_RGB,
    PREDICTED_RGB,
    PathsFolder,
    ReplayFolder,
    SimulationFolder,
)
from app.server.view.parameter_folders import ParameterFolders, assign
from app.server.view.viser_ghost import GhostDrawing

if TYPE_CHECKING:
    import mujoco

    from app.params.presets import PresetStore
    from app.server.jobs.axle_fitter import AxleFitter
    from app.server.jobs.ca_calibrator import CaCalibrator
    from app.server.param_store import ParameterStore
    from app.server.recording.replay import Replay
    from app.server.sim.path_tracker import PathTracker
    from app.server.sim.published import PushMark
    from app.server.sim.sim_thread import SimThread

log = logging.getLogger(__name__)

FRAME_RATE_HZ = 30.0
PATH_REFRESH_S = 0.5
PATH_Z_M = 0.003
PUSH_RGB = (230, 40, 40)
PUSH_SHOWN_S = 1.5  # a push stays drawn this long (simulated time)


class Viewer:
    """The 3D view on its own viser port, drawn in its own thread from what the simulation
    thread publishes (or a replay poses)."""

    def __init__(
        self,
        *,
        store: ParameterStore,
        sim: SimThread,
        paths: PathTracker,
        axle_fitter: AxleFitter,
        ca_calibrator: CaCalibrator,
        presets: PresetStore,
        replay: Replay,
        model: mujoco.MjModel,
        host: str,
        port: int,
    ) -> None:
        self.store = store
        self.sim = sim  # commands, published status and body poses only
        self.paths = paths
        self.axle_fitter = axle_fitter
        self.ca_calibrator = ca_calibrator
        self.presets = presets
        self.replay = replay
        sim.publish_poses = True
        self.server = viser.ViserServer(host=host, port=port, verbose=False)
        # the panel is docked at the right edge and starts minimized: it never covers the robot,
        # which the follow camera keeps in the middle (the page has the motion controls)
        self.server.gui.configure_theme(control_width="medium", show_share_button=False)
        self.server.gui.main_panel.dock_right()
        self.server.gui.main_panel.minimize()
        self._model = model  # the robot drawn; the scene is built again when the robot changes
        self.scene = self._scene_of(model)
        # a 35 cm robot: start close, looking at the trunk from the front left
        self.server.initial_camera.position = (0.55, 0.45, 0.12)
        self.server.initial_camera.look_at = (0.0, 0.0, -0.08)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        gui = self.server.gui  # the panel's folders, top to bottom
        self.simulation = SimulationFolder(
            gui, sim=sim, store=store, presets=presets, replay=replay, follow=self._follow
        )
        self.parameters = ParameterFolders(gui, store)
        self.replay_folder = ReplayFolder(gui, replay=replay, sim=sim)
        self.paths_folder = PathsFolder(
            gui,
            sim=sim,
            store=store,
            paths=paths,
            axle_fitter=axle_fitter,
            ca_calibrator=ca_calibrator,
        )
        self._build_paths()
        self._ghost = GhostDrawing(self.server, model, self.scene.fixed_bodies_frame.name)

    # --- lifecycle ------------------------------------------------------------------------------

    def start(self) -> None:
        self._thread = threading.Thread(target=self._refresh_loop, name="artro-viewer", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self.parameters.close()
        if self._thread is not None:
            self._thread.join(2.0)
        self.server.stop()

    # --- paths ------------------------------------------------------------------------------------

    def _build_paths(self) -> None:
        parent = self.scene.fixed_bodies_frame.name  # moves with the floor when following
        empty = np.zeros((1, 2, 3), dtype=np.float32)
        self._actual = self.server.scene.add_line_segments(
            f"{parent}/path_actual", empty, ACTUAL_RGB, thickness=0.006
        )
        self._predicted = self.server.scene.add_line_segments(
            f"{parent}/path_predicted", empty, PREDICTED_RGB, thickness=0.006
        )
        self._push = self.server.scene.add_line_segments(
            f"{parent}/push", empty, PUSH_RGB, thickness=0.012, visible=False
        )
        self._push_shown: object = None

    def _update_paths(self) -> None:
        view = self.paths.view(max_points=600)
        visible = self.paths_folder.show_paths.value
        for handle, rows in ((self._actual, view["actual"]), (self._predicted, view["predicted"])):
            assign(handle, "visible", visible and len(rows) >= 2)
            if len(rows) >= 2:
                xy = np.asarray(rows, dtype=np.float32)[:, 1:3]
                pts = np.concatenate([xy, np.full((len(xy), 1), PATH_Z_M, np.float32)], axis=1)
                handle.points = np.stack([pts[:-1], pts[1:]], axis=1)
        self.paths_folder.show(view)

    # --- refresh loop -----------------------------------------------------------------------------

    def _refresh_loop(self) -> None:
        shown: tuple[bool, int] | None = None
        next_paths = 0.0
        period = 1.0 / FRAME_RATE_HZ
        while not self._stop.wait(period):
            try:
                if not self.server.get_clients():
                    shown = None  # nobody is watching: no scene updates until someone connects
                    continue
                if self.sim.model is not self._model and not self.replay.active:
                    self._rebuild_scene(self.sim.model)
                    shown = None
                replaying = self.replay.active
                poses = self.replay.poses() if replaying else self.sim.body_poses()
                if poses is not None and poses.model is not self._model:
                    poses = None  # the last robot's, published before the switch: not drawn
                if poses is not None and (replaying, poses.serial) != shown:
                    shown = (replaying, poses.serial)
                    self.scene.update_from_arrays(
                        poses.xpos[None], poses.xmat.reshape(-1, 3, 3)[None]
                    )
                    self._ghost.update(poses.ghost_xpos, poses.ghost_xmat)
                now = time.monotonic()
                if now >= next_paths:
                    next_paths = now + PATH_REFRESH_S
                    self._update_paths()
                    self._update_push()
                    self._update_status()
            except Exception:  # the view must not take the server down
                log.exception("viewer refresh failed")

    def _update_push(self) -> None:
        """The last push as an arrow onto the trunk where it acted, for PUSH_SHOWN_S."""
        s = self.sim.status()
        push = s.push
        recent = push is not None and 0.0 <= s.sim_time_s - push.sim_time_s <= PUSH_SHOWN_S
        assign(self._push, "visible", recent)
        if push is not None and recent and push is not self._push_shown:
            self._push_shown = push
            self._push.points = push_arrow(push)

    def _scene_of(self, model: mujoco.MjModel) -> Any:
        """mjviser's scene of `model`, drawn from a copy: the scene sets the model's display
        settings (sizes of frames, markers), and the simulation's model is the simulation
        thread's (a switch back to a robot seen before shrank them again)."""
        return mjviser.ViserMujocoScene(self.server, copy.copy(model), num_envs=1)

    def _rebuild_scene(self, model: mujoco.MjModel) -> None:
        """Draw another robot: the bodies, the paths and the ghost's bodies anew."""
        self.server.scene.reset()
        self._model = model
        self.scene = self._scene_of(model)
        self._build_paths()
        self._ghost = GhostDrawing(self.server, model, self.scene.fixed_bodies_frame.name)

    def _update_status(self) -> None:
        self.simulation.show(self.sim.status(), self.sim.ghost_status())
        self.replay_folder.show()

    def _follow(self, on: bool) -> None:
        self.scene.camera_tracking_enabled = on


def push_arrow(push: PushMark) -> np.ndarray:
    """(3, 2, 3) line segments of an arrow onto the trunk along the push: the shaft, longer for a
    harder push, and two barbs at the tip."""
    direction = np.radians(push.direction_deg)
    along = np.array([np.cos(direction), np.sin(direction), 0.0])
    tip = np.array([push.x_m, push.y_m, push.z_m])
    tail = tip - along * (0.08 + 0.12 * push.impulse_n_s)
    barbs = []
    for side in (-1.0, 1.0):
        angle = direction + side * np.radians(150.0)
        barbs.append([tip, tip + 0.04 * np.array([np.cos(angle), np.sin(angle), 0.0])])
    return np.array([[tail, tip], *barbs], dtype=np.float32)


def viser_url(host: str, port: int) -> str:
    shown = "localhost" if host in ("127.0.0.1", "0.0.0.0", "::") else host
    return f"http://{shown}:{port}"
