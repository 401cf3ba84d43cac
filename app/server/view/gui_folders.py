"""The 3D view's folders of controls, one class each: Simulation (status, run, speed, follow,
undo/redo, drive, ghost), Replay (scrub the recording) and Paths (what the paths say, the axle
fit, the CA calibration). They send commands and change the store; they never touch MjData."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import viser

from app.analysis.axle_fit import NOT_APPLIED
from app.firmware.emulator import FRAME_CYCLES
from app.server.param_store import NothingToUndo, RobotBusy
from app.server.recording.replay import Replaying
from app.server.sim.live_robot import Drive
from app.server.sim.sim_commands import Reanchor, RemoveGhost, Reset, SetGhost, SetSpeed, control
from app.server.view.parameter_folders import BUTTON_SOURCE, assign

if TYPE_CHECKING:
    from app.params.presets import PresetStore
    from app.server.jobs.axle_fitter import AxleFitter
    from app.server.jobs.ca_calibrator import CaCalibrator
    from app.server.param_store import ParameterStore
    from app.server.recording.replay import Replay
    from app.server.sim.ghost import GhostStatus
    from app.server.sim.path_tracker import PathTracker
    from app.server.sim.published import SimStatus
    from app.server.sim.sim_thread import SimThread

GHOST_OFF = "off"
GHOST_PREVIOUS = "the version before the last change"
ACTUAL_RGB = (30, 110, 230)
PREDICTED_RGB = (235, 120, 20)


class SimulationFolder:
    def __init__(
        self,
        gui: viser.GuiApi,
        *,
        sim: SimThread,
        store: ParameterStore,
        presets: PresetStore,
        replay: Replay,
        follow: Callable[[bool], None],
    ) -> None:
        self.sim, self.store, self.presets, self.replay = sim, store, presets, replay
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

            def set_speed(event: viser.GuiEvent) -> None:
                if event.client is not None:  # a user's drag, not a programmatic set
                    self.sim.send(SetSpeed(speed.value))

            speed.on_update(set_speed)
            following = gui.add_checkbox("Follow the robot", True)
            following.on_update(lambda _e: follow(following.value))
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

    def _reset_with_motion_zero(self) -> None:
        zero = {"a_r": 0.0, "a_p": 0.0, "a_y": 0.0, "ca": 0.0}
        self.store.update({"motion": zero}, BUTTON_SOURCE)
        self.sim.send(Reset())

    def _history(self, which: str, client: viser.ClientHandle | None) -> None:
        try:
            (self.store.undo if which == "Undo" else self.store.redo)(BUTTON_SOURCE)
        except NothingToUndo:
            pass
        except RobotBusy as exc:  # shown to the person who asked; nothing changed
            if client is not None:
                client.add_notification(f"Not {which.lower()}ne", str(exc)[:300], color="red")

    def show(self, s: SimStatus, ghost: GhostStatus | None) -> None:
        """The published status, the drive in use, the ghost shown, the fallen robot's buttons."""
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
        assign(self._status, "content", text)
        assign(self._drive, "value", s.drive)
        shown = GHOST_OFF if ghost is None else ghost.source.removeprefix("preset ")
        if shown in self._ghost_choice.options:
            assign(self._ghost_choice, "value", shown)
        assign(self._fell_notice, "visible", s.fell)
        assign(self._fell_reset, "visible", s.fell)
        assign(self._fell_reset_zero, "visible", s.fell)


class ReplayFolder:
    def __init__(self, gui: viser.GuiApi, *, replay: Replay, sim: SimThread) -> None:
        self.replay, self.sim = replay, sim
        with gui.add_folder("Replay", expand_by_default=False):
            self._text = gui.add_markdown("live")
            self._slider = gui.add_slider(
                "Position (frame)", 0, 1, 1, 0, hint="scrub through the recorded last 60 s"
            )
            self._slider.on_update(self._seek)
            buttons = gui.add_button_group("Recording", ("Replay", "Back to live"))
            buttons.on_click(lambda e: self._button(e.target.value))

    def _button(self, which: str) -> None:
        if which == "Back to live":
            self.replay.leave()
            return
        try:
            self.replay.enter()
        except ValueError:
            return  # nothing recorded yet: the status says "live"
        status = self.replay.status()
        self._slider.max = max(status["frames"] - 1, 1)
        # viser defines the value's setter apart from its getter: mypy takes it as read-only
        self._slider.value = status["index"]  # type: ignore[misc]

    def _seek(self, event: viser.GuiEvent) -> None:
        if event.client is None or not self.replay.active:
            return
        try:
            self.replay.enter(int(self._slider.value))
        except (ValueError, IndexError):
            pass

    def show(self) -> None:
        r = self.replay.status()
        if r["active"]:
            text = f"**replaying** {r['origin']}: frame {r['index'] + 1} of {r['frames']}, "
            text += f"t = {r['t_s']:.2f} s"
            assign(self._slider, "max", max(r["frames"] - 1, 1))
            assign(self._slider, "value", r["index"])
        else:
            text = f"live; {self.sim.recorder.session_s:.0f} s recorded (the last 60 s are kept)"
        assign(self._text, "content", text)


class PathsFolder:
    def __init__(
        self,
        gui: viser.GuiApi,
        *,
        sim: SimThread,
        store: ParameterStore,
        paths: PathTracker,
        axle_fitter: AxleFitter,
        ca_calibrator: CaCalibrator,
    ) -> None:
        self.store, self.paths = store, paths
        self.axle_fitter, self.ca_calibrator = axle_fitter, ca_calibrator
        with gui.add_folder("Paths"):
            self._text = gui.add_markdown("")
            self.show_paths = gui.add_checkbox("Show paths", True)
            anchor = gui.add_button("Re-anchor prediction here")
            anchor.on_click(lambda _e: sim.send(Reanchor()))
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
            self._feet_button.on_click(lambda _e: self._feet_axle())
            self._fit_text = gui.add_markdown("")

    def _feet_axle(self) -> None:
        self.paths.set_axle(None)

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

    def show(self, view: dict[str, Any]) -> None:
        """What the paths say: speed, axle (stale when the gait changed since its fit), turn."""
        radius = view["turn_radius_m"]
        gait = self.store.snapshot().gait
        stale = (
            ", stale: the gait changed" if self.axle_fitter.stale(view["axle_source"], gait) else ""
        )
        assign(
            self._text,
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
