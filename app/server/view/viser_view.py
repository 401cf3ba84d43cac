"""The viser 3D view: the robot (mjviser), schema-generated sliders, paths on the floor, controls.

Built once, refreshed at <= 30 Hz only when something changed and someone watches (docs/DESIGN.md
§10); sliders and store keep one direction of truth (§11).
"""

from __future__ import annotations

import copy
import logging
import threading
import time
from typing import TYPE_CHECKING, Any

import mjviser
import numpy as np
import viser

from app.analysis.axle_fit import NOT_APPLIED
from app.firmware.emulator import FRAME_CYCLES
from app.params.schema import schema_description
from app.server.param_store import NothingToUndo, RobotBusy, Snapshot
from app.server.recording.replay import Replaying
from app.server.sim.live_robot import Drive
from app.server.sim.sim_commands import Reanchor, RemoveGhost, Reset, SetGhost, SetSpeed, control
from app.server.view.viser_ghost import GhostDrawing
from gait.params import ENGINES

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
SLIDER_BURST_S = 1.0  # a slider's updates closer together than this are one gesture: one undo
PATH_REFRESH_S = 0.5
SLIDER_SOURCE = "viser"  # changes made by dragging a slider: the slider already shows them
BUTTON_SOURCE = "viser-button"  # folder resets, undo/redo: the sliders must follow
PATH_Z_M = 0.003
GHOST_OFF = "off"
GHOST_PREVIOUS = "the version before the last change"
ACTUAL_RGB = (30, 110, 230)
PREDICTED_RGB = (235, 120, 20)
PUSH_RGB = (230, 40, 40)
PUSH_SHOWN_S = 1.5  # a push stays drawn this long (simulated time)
DIRECTION_LABELS = {
    "a_r": "a_r (+ steps right)",
    "a_p": "a_p (+ forward)",
    "a_y": "a_y (+ turns clockwise)",
    "ca": "CA (+ left steps longer, clockwise)",
}


class Viewer:
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
        self._controls: dict[tuple[str, str], Any] = {}
        self._bursts: dict[tuple[int, str], tuple[int, float]] = {}  # slider gestures
        # the store announces a change on the thread that committed it: two at once would each
        # read the store and set the sliders, the older possibly last; under this lock the last
        # to set them read the store after every change announced so far
        self._showing = threading.RLock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._build_gui()
        self._build_paths()
        self._ghost = GhostDrawing(self.server, model, self.scene.fixed_bodies_frame.name)
        self._unsubscribe = self.store.subscribe(self._on_params)

    # --- lifecycle ------------------------------------------------------------------------------

    def start(self) -> None:
        self._thread = threading.Thread(target=self._refresh_loop, name="artro-viewer", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._unsubscribe()
        if self._thread is not None:
            self._thread.join(2.0)
        self.server.stop()

    # --- GUI --------------------------------------------------------------------------------------

    def _build_gui(self) -> None:
        gui = self.server.gui
        with gui.add_folder("Simulation"):
            self._status = gui.add_markdown("starting…")
            self._fell_notice = gui.add_markdown("**The robot has fallen.**", visible=False)
            self._fell_reset = gui.add_button("Reset the robot", visible=False, color="red")
            self._fell_reset.on_click(lambda _e: self.sim.send(Reset()))
            self._fell_reset_zero = gui.add_button("Reset with motion 0", visible=False)
            self._fell_reset_zero.on_click(lambda _e: self._reset_with_motion_zero())
            pause = gui.add_button_group("Run", ("Pause", "Resume", "Step", "Reset"))
            pause.on_click(self._run_button)
            speed = gui.add_slider("Speed (x real time)", 0.25, 4.0, 0.25, 1.0)
            speed.on_update(lambda e: e.client and self.sim.send(SetSpeed(speed.value)))
            follow = gui.add_checkbox("Follow the robot", True)
            follow.on_update(
                lambda _e: setattr(self.scene, "camera_tracking_enabled", follow.value)
            )
            history = gui.add_button_group("Parameters", ("Undo", "Redo"))
            history.on_click(lambda e: self._history(e.target.value, e.client))
            self._drive = gui.add_dropdown(
                "Pulses from",
                tuple(d.value for d in Drive),
                initial_value=self.sim.status().drive,
                hint="model: the Python hardware model; firmware: the robot's own firmware on an "
                "emulated ATmega128, the servos read its pins (the robot starts over)",
            )
            self._drive.on_update(self._drive_callback)
            self._ghost_choice = gui.add_dropdown(
                "Ghost (A/B)",
                (GHOST_OFF, *(p.name for p in self.presets.list()), GHOST_PREVIOUS),
                initial_value=GHOST_OFF,
                hint="a second parameter set walks beside the robot, translucent, phase-locked, "
                "with the same motion; the page's Ghost panel compares the two",
            )
            self._ghost_choice.on_update(self._ghost_callback)
        self._folders: list[tuple[Any, list[str]]] = []  # (folder, engines that use its group)
        engine = self.store.snapshot().gait.engine
        self._engine = gui.add_dropdown(
            "Gait engine",
            ENGINES,
            initial_value=engine,
            hint="behnke: seed 000's walking phases; pfs: seed 004's oscillators. Each shows "
            "its own folders; switching is undoable like any change",
        )
        self._engine.on_update(self._engine_callback)
        for group in schema_description():
            self._build_group(group)
        self._show_engine(engine)
        with gui.add_folder("Replay", expand_by_default=False):
            self._replay_text = gui.add_markdown("live")
            self._replay_slider = gui.add_slider(
                "Position (frame)", 0, 1, 1, 0, hint="scrub through the recorded last 60 s"
            )
            self._replay_slider.on_update(self._replay_seek)
            replay_buttons = gui.add_button_group("Recording", ("Replay", "Back to live"))
            replay_buttons.on_click(lambda e: self._replay_button(e.target.value))
        with gui.add_folder("Paths"):
            self._path_text = gui.add_markdown("")
            self._show_paths = gui.add_checkbox("Show paths", True)
            anchor = gui.add_button("Re-anchor prediction here")
            anchor.on_click(lambda _e: self.sim.send(Reanchor()))
            self._fit_button = gui.add_button(
                "Fit the axle b from simulation",
                hint="walk the current gait at CA = -0.1, 0, +0.1 (20 s each, in the background) "
                "and predict with the fitted effective axle b_eff",
            )
            self._fit_button.on_click(lambda _e: self._start_axle_fit())
            self._calibrate_button = gui.add_button(
                "Calibrate CA (steering term K)",
                hint="fit steer.yaw_per_ca forward and backward so that CA turns this gait as "
                "eq (13) says (curve walks in the background); applied as one undoable change",
            )
            self._calibrate_button.on_click(lambda _e: self._start_calibration())
            self._feet_button = gui.add_button("Axle b = distance between the feet")
            self._feet_button.on_click(lambda _e: self.paths.set_axle(None))
            self._fit_text = gui.add_markdown("")

    def _run_button(self, event: viser.GuiEvent) -> None:
        try:
            self.replay.live_command(control(event.target.value.lower()))
        except Replaying as exc:  # told to the person who pressed it; nothing ran
            if event.client is not None:
                event.client.add_notification("Replaying", str(exc)[:300], color="yellow")

    def _drive_callback(self, event: viser.GuiEvent) -> None:
        if event.client is None:  # a programmatic set: the status already says it
            return
        client, drive = event.client, event.target.value

        def switch() -> None:  # building the firmware can take seconds: not in viser's thread
            try:
                self.sim.switch_drive(drive)
            except Exception as exc:  # shown to the person who asked; nothing changed
                client.add_notification("Drive not switched", str(exc)[:300], color="red")

        threading.Thread(target=switch, name="artro-drive-switch", daemon=True).start()

    def _ghost_callback(self, event: viser.GuiEvent) -> None:
        if event.client is None:
            return
        choice = event.target.value
        if choice == GHOST_OFF:
            self.sim.send(RemoveGhost())
        elif choice == GHOST_PREVIOUS:
            versions = self.store.versions()
            if len(versions) < 2:
                event.client.add_notification("No ghost", "no earlier version yet", color="red")
                return
            self.sim.send(SetGhost(versions[1].gait, f"version {versions[1].version}"))
        else:
            self.sim.send(SetGhost(self.presets.get(choice).gait, f"preset {choice}"))

    def _replay_button(self, which: str) -> None:
        if which == "Back to live":
            self.replay.leave()
            return
        try:
            self.replay.enter()
        except ValueError:
            return  # nothing recorded yet: the status says "live"
        status = self.replay.status()
        self._replay_slider.max = max(status["frames"] - 1, 1)
        self._replay_slider.value = status["index"]

    def _replay_seek(self, event: viser.GuiEvent) -> None:
        if event.client is None or not self.replay.active:
            return
        try:
            self.replay.enter(int(self._replay_slider.value))
        except (ValueError, IndexError):
            pass

    def _reset_with_motion_zero(self) -> None:
        zero = {"a_r": 0.0, "a_p": 0.0, "a_y": 0.0, "ca": 0.0}
        self.store.update({"motion": zero}, BUTTON_SOURCE)
        self.sim.send(Reset())

    def _start_calibration(self) -> None:
        self._calibrate_button.disabled = True
        self._fit_text.content = "calibrating CA: curve walks forward and backward …"
        threading.Thread(target=self._calibrate, name="artro-ca-calibration", daemon=True).start()

    def _calibrate(self) -> None:
        try:
            job = self.ca_calibrator.start()
            job.finished.wait()
            if job.status != "done" or job.result is None:
                raise RuntimeError(job.error)
            parts = [
                f"{d}: K = {r['yaw_per_ca']:+.3f} ({100 * r['gain']:.0f} % of eq (13))"
                if "error" not in r
                else f"{d}: {r['error']}"
                for d in ("forward", "backward")
                if (r := job.result.get(d))
            ]
            if job.result.get("conflict"):
                parts.append(f"not applied: {job.result['conflict']['msg']}")
            self._fit_text.content = "  \n".join(parts)
        except Exception as exc:  # a callback thread: say what went wrong instead of dying
            self._fit_text.content = f"no calibration: {exc}"
        finally:
            self._calibrate_button.disabled = False

    def _start_axle_fit(self) -> None:
        self._fit_button.disabled = True
        self._fit_text.content = "fitting: simulating CA = -0.1, 0, +0.1 for 20 s each …"
        threading.Thread(target=self._fit_axle, name="artro-axle-fit", daemon=True).start()

    def _fit_axle(self) -> None:
        snap = self.store.snapshot()
        try:
            r = self.axle_fitter.fit(snap.gait, snap.motion, self.paths)
        except Exception as exc:  # a callback thread: say what went wrong instead of dying
            self._fit_text.content = f"no fit: {exc}"
        else:
            if r["applied"] and r["gain"] is not None:
                self._fit_text.content = (
                    f"b_eff = {100 * r['axle_eff_m']:.1f} cm (feet {100 * r['feet_m']:.1f} cm): "
                    f"CA steers at {100 * r['gain']:.0f} % of eq (13), at a_p = {r['a_p']:+.3f}"
                )
            elif r.get("conflict"):
                self._fit_text.content = f"not applied: {r['conflict']['msg']}"
            else:
                self._fit_text.content = f"not applied: {NOT_APPLIED}"
        finally:
            self._fit_button.disabled = False

    def _build_group(self, group: dict[str, Any]) -> None:
        gui = self.server.gui
        key = group["group"]
        snapshot = self.store.snapshot().flat()
        folder = gui.add_folder(group["title"], expand_by_default=key in ("motion", "clock"))
        self._folders.append((folder, group["engines"]))
        with folder:
            for field in group["fields"]:
                name = field["name"]
                dotted = f"{key}.{name}"
                value = snapshot[dotted]
                hint = f"{field['doc']} — eq {field['eq']}" if field["eq"] else field["doc"]
                if field["unit"] == "bool":
                    handle = gui.add_checkbox(name, bool(value), hint=hint)
                else:
                    label = DIRECTION_LABELS.get(name, name)
                    if field["unit"] not in ("1", "bool"):
                        label = f"{label} [{field['unit']}]"
                    handle = gui.add_slider(
                        label, field["min"], field["max"], field["step"], float(value), hint=hint
                    )
                handle.on_update(self._slider_callback(key, name))
                self._controls[(key, name)] = handle
            reset = gui.add_button(f"Reset {group['title'].lower()} to the paper")
            defaults = {f["name"]: f["default"] for f in group["fields"]}
            reset.on_click(lambda _e, k=key, d=defaults: self._reset_group(k, d))

    def _slider_callback(self, key: str, name: str):
        def on_update(event: viser.GuiEvent) -> None:
            if event.client is None:  # a programmatic set: the store already has it
                return
            value = event.target.value
            patch = {"motion": {name: value}} if key == "motion" else {"gait": {key: {name: value}}}
            gesture = self._gesture(event.client.client_id, f"{key}.{name}")
            try:
                self.store.update(patch, SLIDER_SOURCE, gesture=gesture)
            except ValueError as exc:
                event.client.add_notification("Not applied", str(exc), color="red")
                self._show_store()

        return on_update

    def _gesture(self, client_id: int, dotted: str) -> str:
        """One drag of a slider (its updates less than SLIDER_BURST_S apart) is one gesture."""
        now = time.monotonic()
        count, last = self._bursts.get((client_id, dotted), (0, -SLIDER_BURST_S))
        if now - last > SLIDER_BURST_S:
            count += 1
        self._bursts[(client_id, dotted)] = (count, now)
        return f"viser-{client_id}-{dotted}-{count}"

    def _reset_group(self, key: str, defaults: dict[str, Any]) -> None:
        patch = {"motion": defaults} if key == "motion" else {"gait": {key: defaults}}
        self.store.update(patch, BUTTON_SOURCE)

    def _history(self, which: str, client: viser.ClientHandle | None) -> None:
        try:
            (self.store.undo if which == "Undo" else self.store.redo)(BUTTON_SOURCE)
        except NothingToUndo:
            pass
        except RobotBusy as exc:  # shown to the person who asked; nothing changed
            if client is not None:
                client.add_notification(f"Not {which.lower()}ne", str(exc)[:300], color="red")

    def _engine_callback(self, event: viser.GuiEvent) -> None:
        if event.client is None:  # a programmatic set: the store already has it
            return
        try:
            self.store.update({"gait": {"engine": event.target.value}}, SLIDER_SOURCE)
        except ValueError as exc:
            event.client.add_notification("Not applied", str(exc), color="red")
        self._show_engine(self.store.snapshot().gait.engine)

    def _show_engine(self, engine: str) -> None:
        """Only the folders of the groups the active engine reads."""
        for folder, engines in self._folders:
            _assign(folder, "visible", engine in engines)

    def _on_params(self, snapshot: Snapshot, changed: frozenset[str], source: str) -> None:
        with self._showing:
            if "engine" in changed:
                engine = self.store.snapshot().gait.engine
                _assign(self._engine, "value", engine)
                self._show_engine(engine)
            if source != SLIDER_SOURCE:
                self._show_store(changed)

    def _show_store(self, only: frozenset[str] | None = None) -> None:
        """Set the sliders (all, or those in `only`) to the store's values, read under
        `_showing` (re-entrant: `_on_params` holds it)."""
        with self._showing:
            values = self.store.snapshot().flat()
            for (key, name), handle in self._controls.items():
                dotted = f"{key}.{name}"
                if only is None or dotted in only:
                    handle.value = values[dotted]  # fires the callback with client None: ignored

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
        visible = self._show_paths.value
        for handle, rows in ((self._actual, view["actual"]), (self._predicted, view["predicted"])):
            _assign(handle, "visible", visible and len(rows) >= 2)
            if len(rows) >= 2:
                xy = np.asarray(rows, dtype=np.float32)[:, 1:3]
                pts = np.concatenate([xy, np.full((len(xy), 1), PATH_Z_M, np.float32)], axis=1)
                handle.points = np.stack([pts[:-1], pts[1:]], axis=1)
        radius = view["turn_radius_m"]
        gait = self.store.snapshot().gait
        stale = (
            ", stale: the gait changed" if self.axle_fitter.stale(view["axle_source"], gait) else ""
        )
        _assign(
            self._path_text,
            "content",
            (
                f"<span style='color:rgb{ACTUAL_RGB}'>■ actual</span> "
                f"<span style='color:rgb{PREDICTED_RGB}'>■ predicted</span>  \n"
                f"V = {100 * view['speed_m_s']:.2f} cm/s ({view['speed_source']}), "
                f"b = {100 * view['axle_m']:.1f} cm ({view['axle_source']}{stale})  \n"
                f"turn radius: {'straight' if radius is None else f'{radius:.2f} m'}  \n"
                f"heading rate: predicted {view['predicted_turn_deg_s']:+.1f} °/s, "
                f"actual {view['actual_turn_deg_s']:+.1f} °/s"
            ),
        )

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
        _assign(self._push, "visible", recent)
        if recent and push is not self._push_shown:
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
        s = self.sim.status()
        if s.fell:
            text = f"t = {s.sim_time_s:.1f} s, **fallen — stopped**"
        elif s.paused:
            text = f"t = {s.sim_time_s:.1f} s, paused"
        else:
            rtf = "–" if s.rtf is None else f"{s.rtf:.2f}"
            behind = " — **behind real time**" if s.behind else ""
            text = f"t = {s.sim_time_s:.1f} s, running, real-time factor {rtf} "
            text += f"(target {s.speed:g}×){behind}"
        if s.firmware is not None:
            f = s.firmware
            text += f"  \nPulses from the emulated firmware: MCU frame {f.mcu_frame}, busy "
            text += f"{100 * f.busy_cycles_max / FRAME_CYCLES:.0f} % of a frame (max of 1 s)"
        _assign(self._status, "content", text)
        _assign(self._drive, "value", s.drive)
        r = self.replay.status()
        if r["active"]:
            text = f"**replaying** {r['origin']}: frame {r['index'] + 1} of {r['frames']}, "
            text += f"t = {r['t_s']:.2f} s"
            _assign(self._replay_slider, "max", max(r["frames"] - 1, 1))
            _assign(self._replay_slider, "value", r["index"])
        else:
            text = f"live; {self.sim.recorder.session_s:.0f} s recorded (the last 60 s are kept)"
        _assign(self._replay_text, "content", text)
        ghost = self.sim.ghost_status()
        shown = GHOST_OFF if ghost is None else ghost.source.removeprefix("preset ")
        if shown in self._ghost_choice.options:
            _assign(self._ghost_choice, "value", shown)
        _assign(self._fell_notice, "visible", s.fell)
        _assign(self._fell_reset, "visible", s.fell)
        _assign(self._fell_reset_zero, "visible", s.fell)


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


def _assign(handle: Any, prop: str, value: Any) -> None:
    """Set a handle property only when it changes: every assignment is a message to each client."""
    if getattr(handle, prop) != value:
        setattr(handle, prop, value)


def viser_url(host: str, port: int) -> str:
    shown = "localhost" if host in ("127.0.0.1", "0.0.0.0", "::") else host
    return f"http://{shown}:{port}"
