// The oscilloscope panel: single-frame / roll / cycle views, freeze and replay (the lane choice,
// cursors and readouts: scope-servo-picker.js, scope-cursors.js, scope-readout.js).
// Frames arrive from ScopeFeed at 50/s; the canvas is redrawn at most once per
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
import { scopeCursors } from "./scope-cursors.js";
import { ScopeFeed } from "./scope-feed.js";
import { showRun, updateFpsReadout, updateFrameInfo } from "./scope-readout.js";
import { buildServoPicker, loadServos } from "./scope-servo-picker.js";
import { $, fitCanvas } from "./util.js";

const ROLL_WINDOW_S = 10;

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
const cursors = scopeCursors(state, requestDraw);

export function initScope() {
  state.servos = loadServos();
  buildServoPicker(state.servos, (servos) => {
    state.servos = servos;
    requestDraw();
  });

  $("scope-mode-single").addEventListener("click", () => setMode("single"));
  $("scope-mode-roll").addEventListener("click", () => setMode("roll"));
  $("roll-unit").addEventListener("change", (e) => {
    state.unit = e.target.value;
    requestDraw();
  });
  $("scope-freeze").addEventListener("click", toggleFreeze);
  $("scope-clear-cursors").addEventListener("click", () => {
    state.cursors = { a: null, b: null };
    cursors.updateCursorReadout();
    requestDraw();
  });
  $("scope-canvas").addEventListener("click", cursors.onCanvasClick);
  $("scope-canvas").addEventListener("keydown", cursors.onCanvasKey);
  roll = new RollPlot($("roll-plot"), $("roll-legend"), cursors.setCursor);
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
    showRun(state);
  });
  prefill();
  setInterval(() => updateFpsReadout(feed), 500);
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
  cursors.updateCursorReadout();
  requestDraw();
}

/** Replay: show this recorded frame, frozen (null: back to the live frames). */
export function showRecorded(frame) {
  state.frozen = !!frame;
  state.replaying = !!frame;
  state.frozenFrame = frame;
  if (frame) state.frozenSamples = buffer.toArray();
  $("scope-freeze").disabled = !!frame;
  showRun(state);
  requestDraw();
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
  showRun(state);
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
  const n = state.servos.length;
  const need = mega ? megaFrameMinHeight(frame, n) : singleFrameMinHeight(frame, n);
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

