// Roll view of the scope, drawn by uPlot: each chosen servo's pulse width (µs) or angle (°) against
// simulated time over the last few seconds, gait-cycle starts dashed, saturated samples as orange
// dots, the scope's cursors A/B. The samples come from RollBuffer (roll.js); a click reports the
// time under the pointer to the scope panel, which owns the cursors.

import { drawCursors } from "./scope-axis.js";
import { THEME, UPLOT_AXIS } from "./scope-theme.js";
import { SERVOS, servoColor } from "./util.js";

const uPlot = window.uPlot;
const GAP_S = 0.1; // a hole in the samples longer than this breaks the line (dropped frames)
const LEGEND_EVERY_MS = 200;

export class RollPlot {
  /** el: the element to fill; onClick(t_s, shiftKey) when the plot is clicked. */
  constructor(el, legendEl, onClick) {
    this.el = el;
    this.legendEl = legendEl;
    this.view = { t0: 0, t1: 10, samples: [], idx: [], key: "us", cursors: null };
    this.servosShown = "";
    this.legendAt = 0;
    this.u = null;
    this.onClick = onClick;
    new ResizeObserver(() => this.resize()).observe(el);
  }

  build(idx, key) {
    this.u?.destroy();
    const axis = UPLOT_AXIS;
    this.u = new uPlot(
      {
        width: Math.max(100, this.el.clientWidth),
        height: Math.max(100, this.el.clientHeight),
        legend: { show: false },
        cursor: { drag: { x: false, y: false }, points: { show: false }, y: false },
        scales: {
          x: { time: false, range: () => [this.view.t0, this.view.t1] },
          y: { range: (_u, lo, hi) => yRange(lo, hi, key) },
        },
        axes: [
          { ...axis, label: "sim time (s)", size: 30, labelSize: 12 },
          { ...axis, label: key === "us" ? "pulse width (µs)" : "angle (°)", size: 52, labelSize: 12 },
        ],
        series: [{}, ...idx.map((i) => ({ label: SERVOS[i], stroke: servoColor(SERVOS[i]), width: 1.6, points: { show: false } }))],
        hooks: { draw: [(u) => this.drawMarks(u)] },
      },
      [[]],
      this.el,
    );
    this.u.over.addEventListener("click", (ev) => {
      const t = this.u.posToVal(ev.offsetX, "x");
      if (Number.isFinite(t)) this.onClick(t, ev.shiftKey);
    });
  }

  resize() {
    if (!this.u || !this.el.clientWidth) return;
    const w = Math.floor(this.el.clientWidth);
    const h = Math.floor(this.el.clientHeight);
    if (w !== this.u.width || h !== this.u.height) this.u.setSize({ width: w, height: h });
  }

  /** samples: RollBuffer.toArray(); opts: {servos, unit, windowS, cursors}. */
  update(samples, opts) {
    const idx = opts.servos.map((n) => SERVOS.indexOf(n)).filter((i) => i >= 0);
    const key = opts.unit === "deg" ? "deg" : "us";
    const shape = `${idx.join(",")}|${key}`;
    if (shape !== this.servosShown || !this.u) {
      this.servosShown = shape;
      this.build(idx, key);
    }
    this.resize();
    const t1 = samples.length ? samples[samples.length - 1].t : opts.windowS;
    const t0 = t1 - opts.windowS;
    const visible = samples.filter((s) => s.t >= t0);
    // a gap in time breaks the line: a null sample between the two
    const xs = [];
    const cols = idx.map(() => []);
    let tPrev = -Infinity;
    for (const s of visible) {
      if (s.t - tPrev > GAP_S && xs.length) {
        xs.push((s.t + tPrev) / 2);
        cols.forEach((c) => c.push(null));
      }
      xs.push(s.t);
      idx.forEach((i, k) => cols[k].push(Number.isFinite(s[key][i]) ? s[key][i] : null));
      tPrev = s.t;
    }
    this.view = { t0, t1, samples: visible, idx, key, cursors: opts.cursors };
    this.u.setData([xs, ...cols]);
    this.updateLegend(visible, idx, key);
    window.artro = window.artro || {};
    window.artro.roll = { points: xs.length, series: idx.length };
  }

  updateLegend(visible, idx, key) {
    const now = performance.now();
    if (now - this.legendAt < LEGEND_EVERY_MS) return;
    this.legendAt = now;
    const last = visible[visible.length - 1];
    const unit = key === "us" ? "µs" : "°";
    this.legendEl.replaceChildren(
      ...idx.map((i) => {
        const v = last ? last[key][i] : NaN;
        const item = document.createElement("span");
        item.className = "roll-legend-item";
        item.style.setProperty("--c", servoColor(SERVOS[i]));
        item.textContent = `${SERVOS[i]} ${Number.isFinite(v) ? v.toFixed(1) : "—"}${unit}`;
        return item;
      }),
    );
  }

  drawMarks(u) {
    const { samples, idx, key, cursors } = this.view;
    const ctx = u.ctx;
    const r = uPlot.pxRatio;
    const { left, top, width, height } = u.bbox;
    ctx.save();
    ctx.beginPath();
    ctx.rect(left, top, width, height);
    ctx.clip();
    // gait-cycle starts: where the trunk phase wraps from +π back to −π
    ctx.setLineDash([2 * r, 4 * r]);
    ctx.strokeStyle = THEME.slotLine;
    ctx.lineWidth = r;
    for (let i = 1; i < samples.length; i++) {
      if (samples[i].phase < samples[i - 1].phase - Math.PI) {
        const x = Math.round(u.valToPos(samples[i].t, "x", true)) + 0.5;
        ctx.beginPath();
        ctx.moveTo(x, top);
        ctx.lineTo(x, top + height);
        ctx.stroke();
      }
    }
    ctx.setLineDash([]);
    // saturated samples as orange dots on their line
    ctx.fillStyle = THEME.sat;
    for (const s of samples) {
      for (const i of idx) {
        if (!s.sat[i] || !Number.isFinite(s[key][i])) continue;
        const x = u.valToPos(s.t, "x", true);
        const y = u.valToPos(s[key][i], "y", true);
        ctx.fillRect(x - 2 * r, y - 2 * r, 4 * r, 4 * r);
      }
    }
    ctx.restore();
    // the cursors, in CSS pixels like the single-frame view
    ctx.save();
    ctx.scale(r, r);
    const toX = (t) => u.valToPos(t, "x", true) / r;
    drawCursors(ctx, toX, cursors, top / r, (top + height) / r, [left / r, (left + width) / r]);
    ctx.restore();
  }
}

/** The visible range of the chosen servos, padded, never thinner than 20 µs / 2°. */
function yRange(lo, hi, key) {
  if (lo == null || !Number.isFinite(lo)) [lo, hi] = key === "us" ? [1400, 1600] : [-10, 10];
  const minSpan = key === "us" ? 20 : 2;
  if (hi - lo < minSpan) {
    const mid = (hi + lo) / 2;
    [lo, hi] = [mid - minSpan / 2, mid + minSpan / 2];
  }
  const pad = (hi - lo) * 0.08;
  return [lo - pad, hi + pad];
}
