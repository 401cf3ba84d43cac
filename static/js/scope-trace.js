// Drawing primitives of the scope's lanes: a digital trace (baseline with its high spans), one
// pulse drawn over it, and a lane's label in the left column.

import { THEME } from "./scope-theme.js";

/** Draw a digital trace: `intervals` are the high spans (µs); `hi`/`lo` the y of levels 1/0. */
export function trace(ctx, intervals, ax, hi, lo, color, fill) {
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
export function pulse(ctx, xs, xe, hi, lo, color, fill) {
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

/** The lane's title (bold, in `color`) and an optional dim second line, in the left column. */
export function laneLabel(ctx, lane, title, sub, color) {
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

/** The path of a bus value's box from xs to xe, its ends bevelled to `mid` (stroke or fill it). */
export function busBox(ctx, xs, xe, top, mid, bot, bevel) {
  ctx.beginPath();
  ctx.moveTo(xs, mid);
  ctx.lineTo(xs + bevel, top);
  ctx.lineTo(xe - bevel, top);
  ctx.lineTo(xe, mid);
  ctx.lineTo(xe - bevel, bot);
  ctx.lineTo(xs + bevel, bot);
  ctx.closePath();
}
