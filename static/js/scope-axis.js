// The single frame's time: the x axis (µs from the frame start <-> px), the scope's divisions and
// slot boundaries with slot numbers, the time axis in ms, the trigger mark at t = 0, and the
// vertical cursors A and B (the Mega board's view and the roll plot draw theirs with it too).

import { THEME } from "./scope-theme.js";

export const GUTTER = 92; // left label column, px
export const RIGHT = 14;

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

/** Divisions every 0.5 ms (major every 2 ms), dashed slot boundaries, slot numbers above. */
export function drawGrid(ctx, ax, frame, top, bottom) {
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

/** The time axis in ms along the bottom of the lanes, at y. */
export function drawTimeAxis(ctx, ax, frameUs, y) {
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

/** The frame trigger marker at t = 0: a green arrow and "T" left of the plot, above the lanes. */
export function drawTrigger(ctx, ax, top) {
  ctx.fillStyle = THEME.cursorA;
  ctx.beginPath();
  ctx.moveTo(ax.x0 - 6, top - 14);
  ctx.lineTo(ax.x0, top - 9);
  ctx.lineTo(ax.x0 - 6, top - 4);
  ctx.fill();
  ctx.font = THEME.small;
  ctx.textAlign = "right";
  ctx.textBaseline = "middle";
  ctx.fillText("T", ax.x0 - 9, top - 9);
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
