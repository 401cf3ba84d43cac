// The oscilloscope panel: servo lane choice, single-frame / roll views, cursors, freeze and the
// receive readout. Frames arrive from ScopeFeed at 50/s; the canvas is redrawn at most once per
// animation frame, with the newest frame (or the frozen one), at most every DRAW_MS and never
// more than a DRAW_SHARE of the time (a slow machine draws less often), only while the panel is
// on screen; the frame's text readout at most every INFO_MS. Drawing all 50 frames a second and
// laying the page out for the readout each time kept Chromium's renderer at ~70 % of a core, and
// a busy machine then ran the page's state poll seconds late (issue 33).

import { showBus } from "./scope-bus.js";
import { api } from "./api.js";
import { RollBuffer } from "./roll.js";
import { CyclePlot } from "./cycle-plot.js";
import { RollPlot } from "./roll-plot.js";
import { drawSingleFrame, singleFrameMinHeight } from "./scope.js";
import { drawMegaFrame, megaFrameMinHeight } from "./scope-i2c.js";
import { ScopeFeed } from "./scope-feed.js";
import { $, fitCanvas, h, JOINTS, SERVOS, servoColor } from "./util.js";

const ROLL_WINDOW_S = 10;
const DEFAULT_SERVOS = ["l_hip_pitch", "l_knee", "r_hip_pitch", "r_knee"];
const STORAGE_KEY = "artro.scope.servos";

const state = {
  mode: "single", // "single" | "roll"
  unit: "us", // roll view: "us" | "deg"
  servos: [],
  frozen: false,
  frozenFrame: null,
  frozenSamples: null,
  latest: null,
  cursors: { a: null, b: null },
  axis: null, // what the last draw returned: maps x px <-> time
  sim: "running", // "running" | "paused" | "fallen": what the simulation does (GET /api/state)
  replaying: false,
};
const buffer = new RollBuffer(Math.ceil((ROLL_WINDOW_S / 0.02) * 1.2));
let feed;
let roll;
let cycle;
let drawPending = false;
const DRAW_MS = 40; // 25 pictures a second at most: the eye sees no more on a scope
const DRAW_SHARE = 0.25; // a draw that took t waits t / DRAW_SHARE before the next
let nextDrawAt = 0;
let onScreen = true; // the panel intersects the window (an IntersectionObserver keeps it)
let lastHeight = ""; // the canvas's CSS height last set: set again only when it changes
const INFO_MS = 100; // the frame's readout is rewritten at most this often
let infoShownAt = 0;
let infoTimer = null;
let flagsKey = "";

export function initScope() {
  state.servos = loadServos();
  buildServoPicker();

  $("scope-mode-single").addEventListener("click", () => setMode("single"));
  $("scope-mode-roll").addEventListener("click", () => setMode("roll"));
  $("roll-unit").addEventListener("change", (e) => {
    state.unit = e.target.value;
    requestDraw();
  });
  $("scope-freeze").addEventListener("click", toggleFreeze);
  $("scope-clear-cursors").addEventListener("click", () => {
    state.cursors = { a: null, b: null };
    updateCursorReadout();
    requestDraw();
  });
  $("scope-canvas").addEventListener("click", onCanvasClick);
  $("scope-canvas").addEventListener("keydown", onCanvasKey);
  roll = new RollPlot($("roll-plot"), $("roll-legend"), setCursor);
  cycle = new CyclePlot($("cycle-plot"), $("cycle-info"));
  $("scope-mode-cycle").addEventListener("click", () => setMode("cycle"));
  new ResizeObserver(() => requestDraw()).observe($("scope-wrap"));
  new IntersectionObserver(([entry]) => {
    onScreen = entry.isIntersecting;
    if (onScreen) requestDraw();
  }).observe($("scope-panel"));

  feed = new ScopeFeed({
    onFrame(frame) {
      state.latest = frame;
      buffer.push(frame);
      if (!state.frozen) requestDraw();
    },
    onStatus(text, kind) {
      const el = $("scope-link");
      el.textContent = text;
      el.className = `badge ${kind}`;
      el.hidden = kind === "ok"; // only say something when the link is not live
    },
  });
  feed.connect();
  document.addEventListener("artro:state", (e) => {
    state.sim = e.detail.fell ? "fallen" : e.detail.paused ? "paused" : "running";
    showRun();
  });
  prefill();
  setInterval(updateFpsReadout, 500);
  setMode("single");
}

/** Show recent history at once (and something at all while the simulation is paused or the
 *  robot has fallen, when no live frames come): the last 5 s from GET /api/scope. */
async function prefill() {
  let frames;
  try {
    frames = (await api.get("/api/scope?frames=250")).frames;
  } catch {
    return;
  }
  if (state.latest || !frames?.length) return; // live frames won the race: keep those
  for (const f of frames) buffer.push(f);
  state.latest = frames[frames.length - 1];
  requestDraw();
}

function loadServos() {
  try {
    const saved = JSON.parse(localStorage.getItem(STORAGE_KEY));
    if (Array.isArray(saved)) return SERVOS.filter((s) => saved.includes(s));
  } catch {
    /* ignore a damaged entry */
  }
  return [...DEFAULT_SERVOS];
}

/** Two rows (left leg, right leg) of checkboxes, one per joint, coloured like their traces. */
function buildServoPicker() {
  const box = $("scope-servos");
  box.replaceChildren();
  for (const side of ["l", "r"]) {
    const row = h("div", { class: "servo-row" }, h("span", { class: "servo-side" }, side === "l" ? "Left" : "Right"));
    for (const joint of JOINTS) {
      const name = `${side}_${joint}`;
      const input = h("input", { type: "checkbox", id: `servo-${name}`, value: name, checked: state.servos.includes(name) });
      input.addEventListener("change", () => {
        state.servos = SERVOS.filter((s) => $(`servo-${s}`).checked);
        localStorage.setItem(STORAGE_KEY, JSON.stringify(state.servos));
        requestDraw();
      });
      row.append(
        h("label", { class: "servo-chip", title: name }, input, h("span", { class: "dot", style: `background:${servoColor(name)}` }), joint),
      );
    }
    box.append(row);
  }
  const all = h("button", { type: "button", class: "small", id: "scope-servos-all" }, "All");
  const none = h("button", { type: "button", class: "small", id: "scope-servos-none" }, "None");
  const setAll = (on) => {
    for (const s of SERVOS) $(`servo-${s}`).checked = on;
    state.servos = on ? [...SERVOS] : [];
    localStorage.setItem(STORAGE_KEY, JSON.stringify(state.servos));
    requestDraw();
  };
  all.addEventListener("click", () => setAll(true));
  none.addEventListener("click", () => setAll(false));
  box.lastChild.append(h("span", { class: "spacer" }), all, none);
}

function setMode(mode) {
  state.mode = mode;
  state.cursors = { a: null, b: null };
  for (const m of ["single", "roll", "cycle"]) {
    $(`scope-mode-${m}`).classList.toggle("active", mode === m);
    $(`scope-mode-${m}`).setAttribute("aria-pressed", String(mode === m));
  }
  $("roll-unit-wrap").hidden = mode === "single";
  if (mode === "cycle" && state.unit === "us") {
    state.unit = "deg"; // angles compare left with right; pulse widths carry each servo's direction
    $("roll-unit").value = "deg";
  }
  updateCursorReadout();
  requestDraw();
}

/** Replay: show this recorded frame, frozen (null: back to the live frames). */
export function showRecorded(frame) {
  state.frozen = !!frame;
  state.replaying = !!frame;
  state.frozenFrame = frame;
  if (frame) state.frozenSamples = buffer.toArray();
  $("scope-freeze").disabled = !!frame;
  showRun();
  requestDraw();
}

/** The badge says what the scope shows: a replay, a frozen picture, a fallen or paused robot (no
 *  new frames come then), or frames as they run. */
function showRun() {
  const [text, kind, title] = state.replaying
    ? ["REPLAY", "warn", "a recorded frame of the replay"]
    : state.frozen
      ? ["STOP", "bad", "frozen: frames keep arriving, the picture stays"]
      : state.sim === "fallen"
        ? ["FALLEN", "bad", "the robot has fallen: no new frames until a reset"]
        : state.sim === "paused"
          ? ["PAUSED", "warn", "the simulation is paused: no new frames until it resumes"]
          : ["RUN", "ok", "frames as the simulation makes them"];
  const run = $("scope-run");
  run.textContent = text;
  run.className = `badge ${kind}`;
  run.title = title;
}

function toggleFreeze() {
  state.frozen = !state.frozen;
  if (state.frozen) {
    state.frozenFrame = state.latest;
    state.frozenSamples = buffer.toArray();
  }
  const btn = $("scope-freeze");
  btn.textContent = state.frozen ? "Unfreeze" : "Freeze";
  btn.classList.toggle("active", state.frozen);
  btn.setAttribute("aria-pressed", String(state.frozen));
  showRun();
  requestDraw();
}

function requestDraw() {
  if (drawPending) return;
  drawPending = true;
  const wait = nextDrawAt - performance.now();
  if (wait > 0) setTimeout(() => requestAnimationFrame(draw), wait);
  else requestAnimationFrame(draw);
}

function draw() {
  const started = performance.now();
  drawOnce();
  const took = performance.now() - started;
  nextDrawAt = started + Math.max(DRAW_MS, took / DRAW_SHARE);
}

function drawOnce() {
  drawPending = false;
  if (!onScreen) {
    showFrameInfo(state.frozen ? state.frozenFrame : state.latest);
    return; // drawn when it comes into view
  }
  const canvas = $("scope-canvas");
  const wrap = $("scope-wrap");
  const frame = state.frozen ? state.frozenFrame : state.latest;
  const opts = { servos: state.servos, cursors: state.cursors, unit: state.unit, windowS: ROLL_WINDOW_S };
  canvas.hidden = state.mode !== "single";
  $("roll-wrap").hidden = state.mode !== "roll";
  $("cycle-wrap").hidden = state.mode !== "cycle";
  if (state.mode === "cycle") {
    cycle.update(state.frozen ? state.frozenSamples || [] : buffer.toArray(), opts, state.frozen);
    state.axis = null;
    showFrameInfo(frame);
    return;
  }
  if (state.mode === "roll") {
    roll.update(state.frozen ? state.frozenSamples || [] : buffer.toArray(), opts);
    state.axis = null; // the roll plot reports its clicks itself
    showFrameInfo(frame);
    return;
  }
  // the single-frame view grows taller than the panel when many servo lanes are chosen
  // the Mega board's frames: its PCA9685 channels and I²C bus (scope-i2c.js)
  const mega = Boolean(frame?.pca9685);
  const need = mega ? megaFrameMinHeight(frame) : singleFrameMinHeight(frame, state.servos.length);
  const height = `${Math.max(wrap.clientHeight, need)}px`;
  if (height !== lastHeight) canvas.style.height = lastHeight = height;
  const { ctx, w, h: hgt } = fitCanvas(canvas);
  if (!frame) {
    placeholder(ctx, w, hgt, "waiting for TDM-PWM frames…");
    state.axis = null;
  } else {
    const ax = (mega ? drawMegaFrame : drawSingleFrame)(ctx, w, hgt, frame, opts);
    state.axis = { x0: ax.x0, x1: ax.x1, toTime: ax.toUs };
  }
  showFrameInfo(frame);
}

/** The frame's readout, at most every INFO_MS; the last frame is always shown in the end. */
function showFrameInfo(frame) {
  clearTimeout(infoTimer);
  const wait = infoShownAt + INFO_MS - performance.now();
  if (wait > 0) {
    infoTimer = setTimeout(() => showFrameInfo(frame), wait);
    return;
  }
  infoShownAt = performance.now();
  updateFrameInfo(frame);
  showBus(frame);
}

function placeholder(ctx, w, hgt, text) {
  ctx.fillStyle = "#070b0e";
  ctx.fillRect(0, 0, w, hgt);
  ctx.fillStyle = "#8a9893";
  ctx.font = "14px system-ui, sans-serif";
  ctx.textAlign = "center";
  ctx.textBaseline = "middle";
  ctx.fillText(text, w / 2, hgt / 2);
}

/** Click: cursor A (or B if A is set and B is not); shift-click: cursor B. */
function onCanvasClick(ev) {
  const ax = state.axis;
  if (!ax) return;
  const rect = ev.currentTarget.getBoundingClientRect();
  const x = ev.clientX - rect.left;
  if (x < ax.x0 || x > ax.x1) return;
  setCursor(ax.toTime(x), ev.shiftKey);
}

const KEY_STEP_US = 10; // an arrow moves a cursor 10 µs (Shift: 100 µs; a TDM slot is 2 500 µs)
let keyCursor = "a"; // the cursor the arrows move: the last one placed by key

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
  requestDraw();
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
  requestDraw();
}

/** µs -> "850 µs" or "2.345 ms". */
function fmtFrameTime(us) {
  return Math.abs(us) < 1000 ? `${us.toFixed(1)} µs` : `${(us / 1000).toFixed(3)} ms`;
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

function updateFpsReadout() {
  if (!feed) return;
  const el = $("scope-fps");
  el.textContent = `${feed.fps()} fps · ${feed.dropped} dropped`;
  el.title = `frames received per second (averaged over 2 s) and frames lost (gaps in the frame numbers); ${feed.received} received since the page opened`;
}

function updateFrameInfo(frame) {
  const info = $("scope-info");
  const flags = $("scope-flags");
  if (!frame) {
    info.textContent = "";
    flags.replaceChildren();
    flagsKey = "";
    return;
  }
  const pins = (frame.source === "firmware" ? " · firmware pins" : "") + (frame.recorded ? " · recorded" : "");
  info.textContent = `#${frame.frame} · ${frame.t_s.toFixed(2)} s · φ ${frame.phase_rad.toFixed(2)}${pins}`;
  info.title = `frame number, sim time and trunk phase φ (rad) of the frame shown; parameters v${frame.params_version ?? "?"}`;
  const f = frame.flags || {};
  const key = JSON.stringify([f.guard_violation, f.saturated, f.glitch, f.stray]);
  if (key === flagsKey) return; // the same flags: the page is not laid out again for them
  flagsKey = key;
  const items = [];
  if (f.guard_violation) items.push(h("span", { class: "flag guard" }, "guard violation"));
  if (f.saturated?.length) items.push(h("span", { class: "flag sat" }, `saturated: ${f.saturated.join(", ")}`));
  if (f.glitch?.length) items.push(h("span", { class: "flag glitch" }, `glitch: ${f.glitch.join(", ")}`));
  if (f.stray?.length) items.push(h("span", { class: "flag glitch" }, `stray: ${f.stray.map((s) => s.join("·")).join(", ")}`));
  if (!items.length) items.push(h("span", { class: "flag none" }, "no flags"));
  flags.replaceChildren(...items);
}
