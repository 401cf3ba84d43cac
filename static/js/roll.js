// Roll view: each chosen servo's pulse width (µs) or angle (°) against simulated time, as a strip
// chart over the last ~10 s, fed from a ring buffer of compact per-frame samples.

import { drawCursors, THEME } from "./scope.js";
import { niceStep, SERVOS, servoColor } from "./util.js";

const N = SERVOS.length;

/** Fixed-capacity ring buffer of per-frame samples {t, frame, phase, us[12], deg[12], sat[12]}. */
export class RollBuffer {
  constructor(capacity = 600) {
    this.capacity = capacity;
    this.items = new Array(capacity);
    this.start = 0;
    this.length = 0;
  }

  clear() {
    this.start = 0;
    this.length = 0;
  }

  last() {
    return this.length ? this.items[(this.start + this.length - 1) % this.capacity] : null;
  }

  push(frame) {
    const prev = this.last();
    // the simulation was reset (time went backwards): start a new recording
    if (prev && frame.t_s < prev.t - 1e-9) this.clear();
    const s = {
      t: frame.t_s,
      frame: frame.frame,
      phase: frame.phase_rad,
      us: new Float32Array(N).fill(NaN),
      deg: new Float32Array(N).fill(NaN),
      sat: new Uint8Array(N),
    };
    for (const ch of frame.channels) {
      for (const slot of ch.slots) {
        const i = SERVOS.indexOf(slot.servo);
        if (i < 0) continue;
        // what the servo actually received (the demultiplexed width) drives the robot
        s.us[i] = slot.decoded_us ?? slot.pulse_us;
        s.deg[i] = slot.deg ?? NaN;
        s.sat[i] = slot.saturated ? 1 : 0;
      }
    }
    if (this.length < this.capacity) {
      this.items[(this.start + this.length) % this.capacity] = s;
      this.length++;
    } else {
      this.items[this.start] = s;
      this.start = (this.start + 1) % this.capacity;
    }
  }

  toArray() {
    const out = new Array(this.length);
    for (let i = 0; i < this.length; i++) out[i] = this.items[(this.start + i) % this.capacity];
    return out;
  }
}

const LEFT = 64;
const RIGHT = 14;
const TOP = 26;
const AXIS = 30;
const GAP_S = 0.1; // a hole in the samples longer than this breaks the line (dropped frames)

/**
 * Draw the strip chart. samples: RollBuffer.toArray(); opts: {servos, unit: "us"|"deg",
 * windowS, cursors: {a, b} in seconds of sim time}. Returns {x0, x1, toX, toT}.
 */
export function drawRoll(ctx, w, h, samples, opts) {
  ctx.fillStyle = THEME.bg;
  ctx.fillRect(0, 0, w, h);
  const x0 = LEFT;
  const x1 = w - RIGHT;
  const idx = opts.servos.map((n) => SERVOS.indexOf(n)).filter((i) => i >= 0);
  // lay the legend out first: its rows decide where the plot starts
  ctx.font = THEME.small;
  const legend = [];
  let lx = x0;
  let ly = 11;
  for (const i of idx) {
    const width = ctx.measureText(`${SERVOS[i]} 0000.0µs`).width + 26;
    if (lx + width > x1 && lx > x0) {
      lx = x0;
      ly += 15;
    }
    legend.push({ i, x: lx, y: ly });
    lx += width;
  }
  const y0 = ly + TOP - 11;
  const y1 = h - AXIS;
  const tEnd = samples.length ? samples[samples.length - 1].t : opts.windowS;
  const tStart = tEnd - opts.windowS;
  const toX = (t) => x0 + ((t - tStart) / opts.windowS) * (x1 - x0);
  const toT = (x) => tStart + ((x - x0) / (x1 - x0)) * opts.windowS;
  const key = opts.unit === "deg" ? "deg" : "us";
  const visible = samples.filter((s) => s.t >= tStart);

  // vertical range: the visible data of the chosen servos, padded, never thinner than 20 µs / 2°
  let lo = Infinity;
  let hi = -Infinity;
  for (const s of visible) {
    for (const i of idx) {
      const v = s[key][i];
      if (Number.isFinite(v)) {
        lo = Math.min(lo, v);
        hi = Math.max(hi, v);
      }
    }
  }
  if (!Number.isFinite(lo)) [lo, hi] = key === "us" ? [1400, 1600] : [-10, 10];
  const minSpan = key === "us" ? 20 : 2;
  if (hi - lo < minSpan) {
    const mid = (hi + lo) / 2;
    lo = mid - minSpan / 2;
    hi = mid + minSpan / 2;
  }
  const pad = (hi - lo) * 0.08;
  lo -= pad;
  hi += pad;
  const toY = (v) => y1 - ((v - lo) / (hi - lo)) * (y1 - y0);

  // horizontal grid lines with value labels
  ctx.font = THEME.small;
  ctx.textAlign = "right";
  ctx.textBaseline = "middle";
  const ystep = niceStep(hi - lo, 6);
  for (let v = Math.ceil(lo / ystep) * ystep; v <= hi; v += ystep) {
    const y = Math.round(toY(v)) + 0.5;
    ctx.strokeStyle = THEME.gridMajor;
    ctx.beginPath();
    ctx.moveTo(x0, y);
    ctx.lineTo(x1, y);
    ctx.stroke();
    ctx.fillStyle = THEME.text;
    ctx.fillText(ystep < 1 ? v.toFixed(1) : v.toFixed(0), x0 - 6, y);
  }
  ctx.save();
  ctx.translate(12, (y0 + y1) / 2);
  ctx.rotate(-Math.PI / 2);
  ctx.textAlign = "center";
  ctx.fillStyle = THEME.dim;
  ctx.fillText(key === "us" ? "pulse width (µs)" : "angle (°)", 0, 0);
  ctx.restore();

  // time grid: every `xstep` seconds of sim time
  const xstep = niceStep(opts.windowS, 10);
  ctx.textAlign = "center";
  ctx.textBaseline = "top";
  for (let t = Math.ceil(tStart / xstep) * xstep; t <= tEnd + 1e-9; t += xstep) {
    const x = Math.round(toX(t)) + 0.5;
    ctx.strokeStyle = THEME.gridMinor;
    ctx.beginPath();
    ctx.moveTo(x, y0);
    ctx.lineTo(x, y1);
    ctx.stroke();
    ctx.fillStyle = THEME.text;
    ctx.fillText(`${t.toFixed(xstep < 1 ? 1 : 0)}`, x, y1 + 8);
  }
  ctx.textAlign = "left";
  ctx.fillStyle = THEME.dim;
  ctx.fillText("s", x1 - 8, y1 + 20);

  // gait-cycle starts: where the trunk phase wraps from +π back to −π
  ctx.setLineDash([2, 4]);
  ctx.strokeStyle = THEME.slotLine;
  for (let i = 1; i < visible.length; i++) {
    if (visible[i].phase < visible[i - 1].phase - Math.PI) {
      const x = Math.round(toX(visible[i].t)) + 0.5;
      ctx.beginPath();
      ctx.moveTo(x, y0);
      ctx.lineTo(x, y1);
      ctx.stroke();
    }
  }
  ctx.setLineDash([]);

  // the traces, clipped to the plot; a gap in time breaks the line
  ctx.save();
  ctx.beginPath();
  ctx.rect(x0, y0, x1 - x0, y1 - y0);
  ctx.clip();
  for (const i of idx) {
    ctx.strokeStyle = servoColor(SERVOS[i]);
    ctx.lineWidth = 1.6;
    ctx.beginPath();
    let pen = false;
    let tPrev = -Infinity;
    for (const s of visible) {
      const v = s[key][i];
      if (!Number.isFinite(v) || s.t - tPrev > GAP_S) pen = false;
      if (Number.isFinite(v)) {
        if (pen) ctx.lineTo(toX(s.t), toY(v));
        else ctx.moveTo(toX(s.t), toY(v));
        pen = true;
      }
      tPrev = s.t;
    }
    ctx.stroke();
    // saturated samples as orange dots on the line
    ctx.fillStyle = THEME.sat;
    for (const s of visible) {
      if (s.sat[i] && Number.isFinite(s[key][i])) ctx.fillRect(toX(s.t) - 2, toY(s[key][i]) - 2, 4, 4);
    }
  }
  ctx.restore();

  // legend along the top (wrapping onto more rows): colour, name, latest value
  const last = visible[visible.length - 1];
  ctx.font = THEME.small;
  ctx.textBaseline = "middle";
  ctx.textAlign = "left";
  for (const item of legend) {
    const v = last ? last[key][item.i] : NaN;
    ctx.fillStyle = servoColor(SERVOS[item.i]);
    ctx.fillRect(item.x, item.y - 1, 12, 3);
    ctx.fillStyle = THEME.text;
    ctx.fillText(`${SERVOS[item.i]} ${Number.isFinite(v) ? v.toFixed(1) : "—"}${key === "us" ? "µs" : "°"}`, item.x + 16, item.y);
  }

  ctx.strokeStyle = THEME.gridMajor;
  ctx.strokeRect(x0 + 0.5, y0 + 0.5, x1 - x0 - 1, y1 - y0 - 1);
  drawCursors(ctx, toX, opts.cursors, y0, y1, [x0, x1]);
  return { x0, x1, toX, toT };
}
