// The decoded lanes of the single-frame view: the select bus S2..S0 as one bus lane with its
// value, and one lane per chosen servo (the demultiplexer's output for that servo's line and slot).

import { demuxOutput } from "./scope-model.js";
import { GUTTER } from "./scope-axis.js";
import { fmtDeg, fmtUs } from "./scope-notes.js";
import { THEME } from "./scope-theme.js";
import { busBox, trace } from "./scope-trace.js";
import { servoColor, shortServo } from "./util.js";

/** The select bus as a logic analyser shows a bus: a band per constant value, with the value. */
export function drawBus(ctx, segs, ax, tickUs, lane) {
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
    busBox(ctx, xs, xe, top, mid, bot, bevel);
    ctx.stroke();
    if (xe - xs > 14) {
      ctx.fillStyle = v <= 4 ? THEME.select : THEME.dim;
      ctx.fillText(String(v), (xs + xe) / 2, mid + 0.5);
    }
  }
}

/** A servo's lane: its name and line·slot, its pulse as the demultiplexer passes it, and the
 *  decoded width and angle (with SATURATED, CUT or GLITCH) right of the falling edge. */
export function drawServoLane(ctx, frame, lane, ax, place, selSegs) {
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
