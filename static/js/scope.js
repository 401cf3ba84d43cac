// Single-frame oscilloscope view: one whole 20 ms TDM-PWM frame, triggered at the frame start.
//
// Horizontal: the plot area [GUTTER, w - RIGHT] maps linearly onto [0, frame length] in µs.
// Vertical: lanes stacked top to bottom - the six TDM lines (OC1A..OC3C, with a per-slot
// annotation), the three select lines S0..S2, the decoded select bus, then one lane per chosen
// servo (demultiplexer output = its TDM line AND select == its slot).
// Lane heights have minimums; extra height is shared out proportionally (up to a cap).

import { demuxOutput, highIntervals, selectSegments, servoMap } from "./scope-model.js";
import { servoColor, shortServo } from "./util.js";

export const THEME = {
  bg: "#070b0e",
  gridMinor: "rgba(120, 170, 150, 0.08)",
  gridMajor: "rgba(120, 170, 150, 0.20)",
  slotLine: "rgba(255, 255, 255, 0.30)",
  text: "#b9c6c0",
  dim: "#8a9893", // 6.6:1 on the scope's background
  tdm: "#f2d04b",
  select: "#45c8e0",
  sat: "#ff9a1f",
  guard: "#ff3b3b",
  glitch: "#e64dff",
  cursorA: "#7dff72",
  cursorB: "#ff72d2",
  font: "11px ui-monospace, SFMono-Regular, Menlo, Consolas, monospace",
  small: "10px ui-monospace, SFMono-Regular, Menlo, Consolas, monospace",
};

/** A uPlot axis in the scope's colours (the roll and cycle plots share it). */
export const UPLOT_AXIS = {
  stroke: THEME.text,
  grid: { stroke: THEME.gridMajor, width: 1 },
  ticks: { stroke: THEME.gridMajor, width: 1 },
  font: THEME.small,
  labelFont: THEME.small,
};

export const GUTTER = 92; // left label column, px
export const RIGHT = 14;
const TOP = 22; // slot-number row
const AXIS = 30; // time axis row
const GAP = 8; // between lane groups
const MIN = { tdm: 54, idle: 18, sel: 16, bus: 20, servo: 26 };
const MAX_SCALE = 2.2;

const TDM_NAMES = ["OC1A", "OC1B", "OC1C", "OC3A", "OC3B", "OC3C"];

/** Height in CSS px the single-frame view needs for `frame` with `nServos` servo lanes. */
export function singleFrameMinHeight(frame, nServos) {
  const used = frame ? frame.channels.filter((c) => c.slots.length).length : 6;
  return TOP + AXIS + 3 * GAP + used * MIN.tdm + (6 - used) * MIN.idle + 3 * MIN.sel + MIN.bus + nServos * MIN.servo;
}

/** x pixel <-> µs from frame start, for the plot width w and frame length frameUs. */
export function frameAxis(w, frameUs) {
  const x0 = GUTTER;
  const x1 = w - RIGHT;
  return {
    x0,
    x1,
    toX: (us) => x0 + (us / frameUs) * (x1 - x0),
    toUs: (x) => ((x - x0) / (x1 - x0)) * frameUs,
  };
}

function lanes(frame, servos, h) {
  // a TDM line that carries no pulses gets a thin lane (kind "idle")
  const active = new Set(frame.channels.filter((c) => c.slots.length).map((c) => c.name));
  const items = [
    ...TDM_NAMES.map((name) => ({ kind: active.has(name) ? "tdm" : "idle", name })),
    { kind: "gap" },
    ...["S0", "S1", "S2"].map((name) => ({ kind: "sel", name })),
    { kind: "bus", name: "SEL" },
    { kind: "gap" },
    ...servos.map((name) => ({ kind: "servo", name })),
  ];
  const minSum = items.reduce((a, it) => a + (it.kind === "gap" ? 0 : MIN[it.kind]), 0);
  const free = h - TOP - AXIS - 3 * GAP;
  const scale = Math.min(MAX_SCALE, Math.max(1, free / minSum));
  let y = TOP + GAP;
  for (const it of items) {
    it.y = y;
    it.h = it.kind === "gap" ? GAP : MIN[it.kind] * scale;
    y += it.h;
  }
  return items.filter((it) => it.kind !== "gap");
}

/** Draw a digital trace: `intervals` are the high spans (µs); `hi`/`lo` the y of levels 1/0. */
function trace(ctx, intervals, ax, hi, lo, color, fill) {
  ctx.beginPath();
  ctx.moveTo(ax.x0, lo);
  for (const [s, e] of intervals) {
    const xs = ax.toX(s);
    const xe = ax.toX(e);
    ctx.lineTo(xs, lo);
    ctx.lineTo(xs, hi);
    ctx.lineTo(xe, hi);
    ctx.lineTo(xe, lo);
  }
  ctx.lineTo(ax.x1, lo);
  ctx.strokeStyle = color;
  ctx.lineWidth = 1.5;
  ctx.stroke();
  if (fill) {
    ctx.fillStyle = fill;
    for (const [s, e] of intervals) ctx.fillRect(ax.toX(s), hi, ax.toX(e) - ax.toX(s), lo - hi);
  }
}

/** One high pulse from xs to xe (px), outline and fill, without the baseline around it. */
function pulse(ctx, xs, xe, hi, lo, color, fill) {
  ctx.fillStyle = fill;
  ctx.fillRect(xs, hi, xe - xs, lo - hi);
  ctx.beginPath();
  ctx.moveTo(xs, lo);
  ctx.lineTo(xs, hi);
  ctx.lineTo(xe, hi);
  ctx.lineTo(xe, lo);
  ctx.strokeStyle = color;
  ctx.lineWidth = 2;
  ctx.stroke();
}

function grid(ctx, ax, frame, top, bottom) {
  const frameUs = frame.frame_ticks * frame.tick_us;
  const slotUs = frame.slot_ticks * frame.tick_us;
  // scope divisions: minor every 0.5 ms, major every 2 ms
  for (let us = 0; us <= frameUs + 1e-6; us += 500) {
    const major = us % 2000 === 0;
    ctx.strokeStyle = major ? THEME.gridMajor : THEME.gridMinor;
    ctx.beginPath();
    ctx.moveTo(Math.round(ax.toX(us)) + 0.5, top);
    ctx.lineTo(Math.round(ax.toX(us)) + 0.5, bottom);
    ctx.stroke();
  }
  // slot boundaries every 2.5 ms, dashed, with the slot number centred above each slot
  ctx.setLineDash([4, 4]);
  ctx.strokeStyle = THEME.slotLine;
  const nSlots = Math.round(frameUs / slotUs);
  for (let k = 0; k <= nSlots; k++) {
    const x = Math.round(ax.toX(k * slotUs)) + 0.5;
    ctx.beginPath();
    ctx.moveTo(x, top - 16);
    ctx.lineTo(x, bottom);
    ctx.stroke();
  }
  ctx.setLineDash([]);
  const used = new Set(frame.channels.flatMap((c) => c.slots.map((s) => s.slot)));
  ctx.font = THEME.font;
  ctx.textAlign = "center";
  ctx.textBaseline = "middle";
  const slotW = ax.toX(slotUs) - ax.x0;
  for (let k = 0; k < nSlots; k++) {
    ctx.fillStyle = used.has(k) ? THEME.text : THEME.dim;
    const words = used.has(k) ? [`slot ${k}`, `${k}`] : [`slot ${k} idle`, `${k} idle`, `${k}`];
    const label = words.find((t) => ctx.measureText(t).width < slotW - 8) ?? `${k}`;
    ctx.fillText(label, ax.toX((k + 0.5) * slotUs), top - 9);
  }
}

function timeAxis(ctx, ax, frameUs, y) {
  ctx.strokeStyle = THEME.gridMajor;
  ctx.beginPath();
  ctx.moveTo(ax.x0, y + 0.5);
  ctx.lineTo(ax.x1, y + 0.5);
  ctx.stroke();
  ctx.font = THEME.font;
  ctx.fillStyle = THEME.text;
  ctx.textBaseline = "top";
  for (let us = 0; us <= frameUs + 1e-6; us += 500) {
    const x = Math.round(ax.toX(us)) + 0.5;
    const major = us % 2500 === 0;
    ctx.strokeStyle = THEME.text;
    ctx.beginPath();
    ctx.moveTo(x, y);
    ctx.lineTo(x, y + (major ? 6 : 3));
    ctx.stroke();
    if (major) {
      ctx.textAlign = us === 0 ? "left" : us >= frameUs ? "right" : "center";
      ctx.fillText(`${(us / 1000).toFixed(1)}`, x, y + 8);
    }
  }
  ctx.textAlign = "left";
  ctx.fillStyle = THEME.dim;
  ctx.fillText("ms", ax.x0 - 40, y + 8);
}

function laneLabel(ctx, lane, title, sub, color) {
  ctx.textAlign = "left";
  ctx.textBaseline = "top";
  ctx.font = `bold ${THEME.font}`;
  ctx.fillStyle = color;
  ctx.fillText(title, 8, lane.y + 3);
  if (sub) {
    ctx.font = THEME.small;
    ctx.fillStyle = THEME.dim;
    ctx.fillText(sub, 8, lane.y + 17);
  }
}

const fmtUs = (us) => (us == null ? "—" : `${Number(us).toFixed(1)}µs`);
const fmtDeg = (d) => (d == null ? "" : `${d >= 0 ? "+" : ""}${Number(d).toFixed(1)}°`);

/** The wordings of a slot's note, longest first: servo (name or short), pulse width, angle. */
const NOTE_FORMS = [
  (n) => [n.name, `${n.us} ${n.deg}`],
  (n) => [n.short, `${n.us} ${n.deg}`],
  (n) => [n.name, n.us, n.deg],
  (n) => [n.short, n.us, n.deg],
  (n) => [`${n.short} ${n.deg}`, n.us],
  (n) => [n.short, n.us],
  (n) => [n.us],
];
const NOTE_LINE_H = 11;

const noteWords = (s) => ({
  name: s.servo ?? "stray", short: shortServo(s.servo), us: fmtUs(s.pulse_us), deg: fmtDeg(s.deg),
});

/** One wording for every slot note of the frame: the longest form that fits each slot's width
 *  and the lines below its trace, so the labels never mix two styles. notes: [{s, width, height}]. */
function noteForm(ctx, notes) {
  ctx.font = THEME.small;
  const fits = (form, { s, width, height }) => {
    const words = NOTE_FORMS[form](noteWords(s));
    const rows = Math.max(1, Math.floor(height / NOTE_LINE_H));
    return words.length <= rows && words.every((t) => ctx.measureText(t).width <= width - 6);
  };
  const form = NOTE_FORMS.findIndex((_, f) => notes.every((n) => fits(f, n)));
  return form < 0 ? NOTE_FORMS.length - 1 : form;
}

/** Annotate one slot of a TDM line with servo, pulse width and angle in the frame's form. */
function slotNote(ctx, s, xLeft, yTop, form) {
  const chosen = NOTE_FORMS[form](noteWords(s));
  ctx.font = THEME.small;
  const color = s.guard_violation ? THEME.guard : s.saturated ? THEME.sat : THEME.text;
  ctx.textAlign = "left";
  ctx.textBaseline = "top";
  chosen.forEach((t, i) => {
    ctx.fillStyle = i === 0 ? (s.servo ? servoColor(s.servo) : THEME.glitch) : color;
    ctx.fillText(t, xLeft + 4, yTop + i * NOTE_LINE_H);
  });
}

/**
 * Draw one frame. opts: {servos: [names], cursors: {a, b} in µs or null}.
 * Returns the x axis so callers can map mouse clicks to µs.
 */
export function drawSingleFrame(ctx, w, h, frame, opts) {
  ctx.fillStyle = THEME.bg;
  ctx.fillRect(0, 0, w, h);
  const frameUs = frame.frame_ticks * frame.tick_us;
  const slotUs = frame.slot_ticks * frame.tick_us;
  const tickUs = frame.tick_us;
  const ax = frameAxis(w, frameUs);
  const ls = lanes(frame, opts.servos, h);
  const bottom = ls.length ? ls[ls.length - 1].y + ls[ls.length - 1].h : h - AXIS;
  const toUs = (iv) => iv.map(([s, e]) => [s * tickUs, e * tickUs]);

  grid(ctx, ax, frame, TOP, bottom);

  // guard violations: a red band where the select lines moved while a TDM line was still high
  const selChangeUs = frame.select_change_ticks * tickUs;
  const guardSlots = new Set();
  for (const ch of frame.channels) for (const s of ch.slots) if (s.guard_violation) guardSlots.add(s.slot);
  for (const k of guardSlots) {
    const x = ax.toX(k * slotUs + selChangeUs);
    ctx.fillStyle = "rgba(255, 59, 59, 0.28)";
    ctx.fillRect(x - 4, TOP, 8, bottom - TOP);
    ctx.fillStyle = THEME.guard;
    ctx.fillRect(x - 1, TOP, 2, bottom - TOP);
  }

  const selSegs = selectSegments(frame);
  const where = servoMap(frame);
  const lineByName = new Map(frame.lines.map((l) => [l.name, l]));
  const chByName = new Map(frame.channels.map((c) => [c.name, c]));
  const noteTop = (lane) => lane.y + 4 + Math.min(20, lane.h * 0.3) + 2;
  const slotW = ax.toX(slotUs) - ax.x0;
  const notes = ls.filter((l) => l.kind === "tdm").flatMap((lane) =>
    (chByName.get(lane.name)?.slots ?? []).map((s) =>
      ({ s, width: slotW, height: lane.y + lane.h - noteTop(lane) })));
  const form = noteForm(ctx, notes);
  // what each slot's note begins with, for a reader that cannot see the canvas (the tests)
  ctx.canvas.dataset.slotLabels = JSON.stringify(notes.map(({ s }) => NOTE_FORMS[form](noteWords(s))[0]));

  for (const lane of ls) {
    if (lane.kind === "idle") {
      // a TDM line with no servo pulses this frame: label and a flat trace only
      laneLabel(ctx, lane, lane.name, null, THEME.dim);
      ctx.font = THEME.small;
      ctx.fillStyle = THEME.dim;
      ctx.textAlign = "right";
      ctx.fillText("idle", GUTTER - 8, lane.y + 4);
      const line = lineByName.get(lane.name);
      const iv = line ? toUs(highIntervals(line.initial, line.edges, frame.frame_ticks)) : [];
      trace(ctx, iv, ax, lane.y + 4, lane.y + lane.h - 4, THEME.dim);
    } else if (lane.kind === "tdm") {
      const line = lineByName.get(lane.name);
      const ch = chByName.get(lane.name);
      const hi = lane.y + 4;
      const lo = hi + Math.min(20, lane.h * 0.3);
      const nActive = ch.slots.length;
      laneLabel(ctx, lane, lane.name, `${nActive} servo${nActive > 1 ? "s" : ""}`, THEME.tdm);
      if (!line) continue;
      const iv = toUs(highIntervals(line.initial, line.edges, frame.frame_ticks));
      trace(ctx, iv, ax, hi, lo, THEME.tdm, "rgba(242, 208, 75, 0.10)");
      for (const s of ch ? ch.slots : []) {
        const x = ax.toX(s.slot * slotUs);
        if (s.saturated) {
          // re-draw this slot's pulse in orange over the yellow one
          const fall = (s.slot * frame.slot_ticks + s.ocr_ticks + 1) * tickUs;
          pulse(ctx, x, ax.toX(fall), hi, lo, THEME.sat, "rgba(255, 154, 31, 0.25)");
        }
        slotNote(ctx, s, x, noteTop(lane), form);
      }
    } else if (lane.kind === "sel") {
      const line = lineByName.get(lane.name);
      laneLabel(ctx, lane, lane.name, null, THEME.select);
      if (!line) continue;
      const hi = lane.y + 3;
      const lo = lane.y + lane.h - 3;
      trace(ctx, toUs(highIntervals(line.initial, line.edges, frame.frame_ticks)), ax, hi, lo, THEME.select);
    } else if (lane.kind === "bus") {
      laneLabel(ctx, lane, "SEL", null, THEME.select);
      drawBus(ctx, selSegs, ax, tickUs, lane);
    } else if (lane.kind === "servo") {
      drawServoLane(ctx, frame, lane, ax, where.get(lane.name), selSegs);
    }
  }

  timeAxis(ctx, ax, frameUs, bottom + 4);

  // frame trigger marker at t = 0
  ctx.fillStyle = THEME.cursorA;
  ctx.beginPath();
  ctx.moveTo(ax.x0 - 6, TOP - 14);
  ctx.lineTo(ax.x0, TOP - 9);
  ctx.lineTo(ax.x0 - 6, TOP - 4);
  ctx.fill();
  ctx.font = THEME.small;
  ctx.textAlign = "right";
  ctx.textBaseline = "middle";
  ctx.fillText("T", ax.x0 - 9, TOP - 9);

  drawCursors(ctx, ax.toX, opts.cursors, TOP, bottom, [ax.x0, ax.x1]);
  return ax;
}

/** The select bus as a logic analyser shows a bus: a band per constant value, with the value. */
function drawBus(ctx, segs, ax, tickUs, lane) {
  const top = lane.y + 3;
  const bot = lane.y + lane.h - 3;
  const mid = (top + bot) / 2;
  ctx.lineWidth = 1.2;
  ctx.font = THEME.small;
  ctx.textAlign = "center";
  ctx.textBaseline = "middle";
  for (const [s, e, v] of segs) {
    const xs = ax.toX(s * tickUs);
    const xe = ax.toX(e * tickUs);
    const bevel = Math.min(3, (xe - xs) / 3);
    ctx.strokeStyle = v <= 4 ? THEME.select : THEME.dim;
    ctx.beginPath();
    ctx.moveTo(xs, mid);
    ctx.lineTo(xs + bevel, top);
    ctx.lineTo(xe - bevel, top);
    ctx.lineTo(xe, mid);
    ctx.lineTo(xe - bevel, bot);
    ctx.lineTo(xs + bevel, bot);
    ctx.closePath();
    ctx.stroke();
    if (xe - xs > 14) {
      ctx.fillStyle = v <= 4 ? THEME.select : THEME.dim;
      ctx.fillText(String(v), (xs + xe) / 2, mid + 0.5);
    }
  }
}

function drawServoLane(ctx, frame, lane, ax, place, selSegs) {
  const color = servoColor(lane.name);
  const sub = place ? `${place.channel}·${place.slot}` : "not mapped";
  ctx.textAlign = "left";
  ctx.textBaseline = "top";
  ctx.font = `bold ${THEME.small}`;
  ctx.fillStyle = color;
  const label = ctx.measureText(lane.name).width < GUTTER - 12 ? lane.name : shortServo(lane.name);
  ctx.fillText(label, 8, lane.y + 3);
  ctx.font = THEME.small;
  ctx.fillStyle = THEME.dim;
  ctx.fillText(sub, 8, lane.y + 15);
  // a faint separator between servo lanes
  ctx.strokeStyle = "rgba(255,255,255,0.05)";
  ctx.beginPath();
  ctx.moveTo(ax.x0, lane.y + 0.5);
  ctx.lineTo(ax.x1, lane.y + 0.5);
  ctx.stroke();
  const hi = lane.y + 5;
  const lo = lane.y + lane.h - 6;
  if (!place) {
    trace(ctx, [], ax, hi, lo, THEME.dim);
    return;
  }
  const info = place.info;
  const iv = demuxOutput(frame, place.channel, place.slot, selSegs).map(([s, e]) => [s * frame.tick_us, e * frame.tick_us]);
  const c = info.saturated ? THEME.sat : info.glitch ? THEME.glitch : color;
  trace(ctx, iv, ax, hi, lo, c, `${c}22`);
  // annotate right of the (first) falling edge: decoded width and angle
  const fallUs = iv.length ? iv[0][1] : (place.slot * frame.slot_ticks) * frame.tick_us;
  const parts = [fmtUs(info.decoded_us ?? info.pulse_us), fmtDeg(info.deg)];
  if (info.saturated) parts.push("SATURATED");
  if (info.guard_violation) parts.push("CUT");
  if (info.glitch) parts.push("GLITCH");
  ctx.font = THEME.small;
  ctx.textBaseline = "middle";
  ctx.fillStyle = info.guard_violation ? THEME.guard : info.saturated ? THEME.sat : info.glitch ? THEME.glitch : THEME.text;
  ctx.fillText(parts.filter(Boolean).join("  "), ax.toX(fallUs) + 6, (hi + lo) / 2);
}

/** Vertical cursor lines A and B with their letters at the top; xs in CSS px via toX. */
export function drawCursors(ctx, toX, cursors, top, bottom, [xmin, xmax]) {
  if (!cursors) return;
  for (const [key, color] of [["a", THEME.cursorA], ["b", THEME.cursorB]]) {
    const v = cursors[key];
    if (v == null) continue;
    const x = Math.round(toX(v)) + 0.5;
    if (x < xmin || x > xmax) continue;
    ctx.strokeStyle = color;
    ctx.lineWidth = 1;
    ctx.setLineDash(key === "b" ? [5, 3] : []);
    ctx.beginPath();
    ctx.moveTo(x, top);
    ctx.lineTo(x, bottom);
    ctx.stroke();
    ctx.setLineDash([]);
    ctx.fillStyle = color;
    ctx.fillRect(x - 7, top, 14, 13);
    ctx.fillStyle = "#000";
    ctx.font = `bold ${THEME.small}`;
    ctx.textAlign = "center";
    ctx.textBaseline = "middle";
    ctx.fillText(key.toUpperCase(), x, top + 7);
  }
}
