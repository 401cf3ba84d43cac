// The scope's cursors A and B: placed by a click (shift-click: B) or, on the single-frame view, by
// keys (A, B, ←/→, Escape); and their readout under the scope: times, Δt and its frequency.

import { $ } from "./util.js";

const KEY_STEP_US = 10; // an arrow moves a cursor 10 µs (Shift: 100 µs; a TDM slot is 2 500 µs)

/** µs -> "850 µs" or "2.345 ms". */
function fmtFrameTime(us) {
  return Math.abs(us) < 1000 ? `${us.toFixed(1)} µs` : `${(us / 1000).toFixed(3)} ms`;
}

/** The cursors of the panel's `state` (its cursors, mode and axis: what the last draw returned);
 *  `redraw()` after every change. Returns the handlers the panel wires up. */
export function scopeCursors(state, redraw) {
  let keyCursor = "a"; // the cursor the arrows move: the last one placed by key

  /** Click: cursor A (or B if A is set and B is not); shift-click: cursor B. */
  function onCanvasClick(ev) {
    const ax = state.axis;
    if (!ax) return;
    const rect = ev.currentTarget.getBoundingClientRect();
    const x = ev.clientX - rect.left;
    if (x < ax.x0 || x > ax.x1) return;
    setCursor(ax.toTime(x), ev.shiftKey);
  }

  /** Keys on the single-frame view: A or B places that cursor (mid-frame if unset), ←/→ move
   * it (Shift: ×10), Escape clears both. */
  function onCanvasKey(ev) {
    const ax = state.axis;
    if (!ax || ev.ctrlKey || ev.metaKey || ev.altKey) return;
    const frameUs = ax.toTime(ax.x1);
    const c = state.cursors;
    const key = ev.key.toLowerCase();
    if (key === "a" || key === "b") {
      keyCursor = key;
      if (c[key] == null) c[key] = frameUs / 2;
    } else if (ev.key === "ArrowLeft" || ev.key === "ArrowRight") {
      const step = (ev.key === "ArrowLeft" ? -1 : 1) * KEY_STEP_US * (ev.shiftKey ? 10 : 1);
      const from = c[keyCursor] ?? frameUs / 2;
      c[keyCursor] = Math.min(frameUs, Math.max(0, from + step));
    } else if (ev.key === "Escape") {
      state.cursors = { a: null, b: null };
    } else {
      return;
    }
    ev.preventDefault();
    updateCursorReadout();
    redraw();
  }

  /** Cursor A at `t`, or B if A is set and B is not (or with shift). */
  function setCursor(t, shiftKey) {
    const c = state.cursors;
    if (shiftKey || (c.a != null && c.b == null)) c.b = t;
    else {
      c.a = t;
      c.b = null;
    }
    updateCursorReadout();
    redraw();
  }

  function updateCursorReadout() {
    const { a, b } = state.cursors;
    const el = $("scope-cursors");
    if (a == null && b == null) {
      el.textContent =
        state.mode === "cycle"
          ? "cycle view: hover for values"
          : state.mode === "single"
            ? "cursors: click = A, shift-click or 2nd click = B; keys (scope focused): A, B, ← →"
            : "cursors: click = A, shift-click or 2nd click = B";
      el.classList.add("dim");
      return;
    }
    el.classList.remove("dim");
    const f = state.mode === "single" ? fmtFrameTime : (s) => `${s.toFixed(3)} s`;
    const parts = [];
    if (a != null) parts.push(`A ${f(a)}`);
    if (b != null) parts.push(`B ${f(b)}`);
    if (a != null && b != null) {
      const d = b - a;
      const seconds = state.mode === "single" ? d * 1e-6 : d;
      const hz = Math.abs(seconds) > 0 ? ` · ${(1 / Math.abs(seconds)).toFixed(Math.abs(seconds) < 0.01 ? 0 : 2)} Hz` : "";
      parts.push(`Δt ${f(d)}${hz}`);
    }
    el.textContent = parts.join("   ");
  }

  return { onCanvasClick, onCanvasKey, setCursor, updateCursorReadout };
}
