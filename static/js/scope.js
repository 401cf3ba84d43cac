// Single-frame oscilloscope view: one whole 20 ms TDM-PWM frame, triggered at the frame start.
//
// Horizontal: the plot area [GUTTER, w - RIGHT] maps linearly onto [0, frame length] in µs
// (scope-axis.js: axis, grid, cursors; the lanes: scope-trace.js, scope-notes.js,
// scope-decoded-lanes.js).
// Vertical: lanes stacked top to bottom - the six TDM lines (OC1A..OC3C, with a per-slot
// annotation), the three select lines S0..S2, the decoded select bus, then one lane per chosen
// servo (demultiplexer output = its TDM line AND select == its slot).
// Lane heights have minimums; extra height is shared out proportionally (up to a cap).

import { drawCursors, drawGrid, drawTimeAxis, drawTrigger, frameAxis, GUTTER } from "./scope-axis.js";
import { drawBus, drawServoLane } from "./scope-decoded-lanes.js";
import { highIntervals, selectSegments, servoMap } from "./scope-model.js";
import { NOTE_FORMS, noteForm, noteWords, slotNote } from "./scope-notes.js";
import { THEME } from "./scope-theme.js";
import { laneLabel, pulse, trace } from "./scope-trace.js";

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

  drawGrid(ctx, ax, frame, TOP, bottom);

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

  drawTimeAxis(ctx, ax, frameUs, bottom + 4);

  drawTrigger(ctx, ax, TOP);
  drawCursors(ctx, ax.toX, opts.cursors, TOP, bottom, [ax.x0, ax.x1]);
  return ax;
}
