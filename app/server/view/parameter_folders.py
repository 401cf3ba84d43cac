"""The 3D view's parameter folders: the gait engine's choice and one folder of sliders per group
of the parameter schema, generated from it (no widget wired by hand), a drag one undo step; the
sliders follow the store with one direction of truth (docs/DESIGN.md §10, §11)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import viser

from app.params.schema import schema_description
from app.server.param_store import Snapshot
from gait.params import ENGINES

if TYPE_CHECKING:
    from app.server.param_store import ParameterStore

SLIDER_BURST_S = 1.0  # a slider's updates closer together than this are one gesture: one undo
SLIDER_SOURCE = "viser"  # changes made by dragging a slider: the slider already shows them
BUTTON_SOURCE = "viser-button"  # folder resets, undo/redo: the sliders must follow
DIRECTION_LABELS = {
    "a_r": "a_r (+ steps right)",
    "a_p": "a_p (+ forward)",
    "a_y": "a_y (+ turns clockwise)",
    "ca": "CA (+ left steps longer, clockwise)",
}


class ParameterFolders:
    """The engine dropdown and the schema's folders, built once; `close` stops following."""

    def __init__(self, gui: viser.GuiApi, store: ParameterStore) -> None:
        self.gui, self.store = gui, store
        self.controls: dict[tuple[str, str], Any] = {}
        self._bursts: dict[tuple[int, str], tuple[int, float]] = {}  # slider gestures
        # the store announces a change on the thread that committed it: two at once would each
        # read the store and set the sliders, the older possibly last; under this lock the last
        # to set them read the store after every change announced so far
        self._showing = threading.RLock()
        self.folders: list[tuple[Any, list[str]]] = []  # (folder, engines that use its group)
        engine = store.snapshot().gait.engine
        self.engine = gui.add_dropdown(
            "Gait engine",
            ENGINES,
            initial_value=engine,
            hint="behnke: seed 000's walking phases; pfs: seed 004's oscillators. Each shows "
            "its own folders; switching is undoable like any change",
        )
        self.engine.on_update(self._engine_callback)
        for group in schema_description():
            self._build_group(group)
        self._show_engine(engine)
        self._unsubscribe = store.subscribe(self._on_params)

    def close(self) -> None:
        self._unsubscribe()

    def _build_group(self, group: dict[str, Any]) -> None:
        gui = self.gui
        key = group["group"]
        snapshot = self.store.snapshot().flat()
        folder = gui.add_folder(group["title"], expand_by_default=key in ("motion", "clock"))
        self.folders.append((folder, group["engines"]))
        with folder:
            for field in group["fields"]:
                name = field["name"]
                dotted = f"{key}.{name}"
                value = snapshot[dotted]
                hint = f"{field['doc']} — eq {field['eq']}" if field["eq"] else field["doc"]
                handle: viser.GuiInputHandle[Any]
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
                self.controls[(key, name)] = handle
            reset = gui.add_button(f"Reset {group['title'].lower()} to the paper")
            defaults = {f["name"]: f["default"] for f in group["fields"]}
            reset.on_click(lambda _e: self._reset_group(key, defaults))

    def _slider_callback(self, key: str, name: str) -> Callable[[viser.GuiEvent], None]:
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
        for folder, engines in self.folders:
            assign(folder, "visible", engine in engines)

    def _on_params(self, snapshot: Snapshot, changed: frozenset[str], source: str) -> None:
        with self._showing:
            if "engine" in changed:
                engine = self.store.snapshot().gait.engine
                assign(self.engine, "value", engine)
                self._show_engine(engine)
            if source != SLIDER_SOURCE:
                self._show_store(changed)

    def _show_store(self, only: frozenset[str] | None = None) -> None:
        """Set the sliders (all, or those in `only`) to the store's values, read under
        `_showing` (re-entrant: `_on_params` holds it)."""
        with self._showing:
            values = self.store.snapshot().flat()
            for (key, name), handle in self.controls.items():
                dotted = f"{key}.{name}"
                if only is None or dotted in only:
                    handle.value = values[dotted]  # fires the callback with client None: ignored


def assign(handle: Any, prop: str, value: Any) -> None:
    """Set a handle property only when it changes: every assignment is a message to each client."""
    if getattr(handle, prop) != value:
        setattr(handle, prop, value)
