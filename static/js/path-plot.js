// The top view of the trunk paths, drawn by uPlot (static/vendor/uplot, loaded as a classic script):
// the actual path, the differential-drive prediction (docs/DESIGN.md §4), and optionally the mean
// position of each whole gait cycle (the sway averaged out). World frame x forward, y left, drawn
// with x to the right and y up, one metre per pixel scale on both axes so circles look round.
// The robot (a triangle along its heading) and the anchor are drawn in uPlot's draw hook.
// Both paths are drawn point after point (`inOrder`): uPlot's own linear() path merges points per
// pixel column once there are four per column, and assumes x increases (a walk turns back).

const uPlot = window.uPlot;
const COLORS = {
  grid: "rgba(150, 170, 190, 0.12)",
  text: "#9fb0bf",
  actual: "#4dabf7",
  predicted: "#ff922b",
  cycles: "#b2f2bb",
  robot: "#e9f1f7",
  anchor: "#ffd43b",
};
const MIN_SPAN_M = 0.4;

export class PathPlot {
  constructor(el) {
    this.el = el;
    this.last = null;
    const axis = {
      stroke: COLORS.text,
      grid: { stroke: COLORS.grid, width: 1 },
      ticks: { stroke: COLORS.grid, width: 1 },
      font: "10px ui-monospace, Menlo, Consolas, monospace",
      labelFont: "11px system-ui, sans-serif",
    };
    const line = (label, stroke, width, dash) => ({
      label,
      stroke,
      width,
      dash,
      paths: inOrder,
      points: { show: false },
      facets: [{ scale: "x", auto: false }, { scale: "y", auto: false }],
    });
    this.u = new uPlot(
      {
        mode: 2,
        width: Math.max(100, el.clientWidth),
        height: Math.max(100, el.clientHeight),
        legend: { show: false },
        cursor: { show: false },
        scales: { x: { time: false, auto: false }, y: { auto: false } },
        axes: [
          { ...axis, label: "x (m) → forward", size: 34, labelSize: 14 },
          { ...axis, label: "y (m) ↑ left", size: 44, labelSize: 14 },
        ],
        series: [
          {},
          line("predicted", COLORS.predicted, 2, [6, 4]),
          line("actual", COLORS.actual, 1.5),
          { ...line("cycle means", COLORS.cycles, 1.5), points: { show: true, size: 4, fill: COLORS.cycles } },
        ],
        hooks: { draw: [(u) => this.drawMarks(u)] },
      },
      [null, [[], []], [[], []], [[], []]],
      el,
    );
    new ResizeObserver(() => this.resize()).observe(el);
  }

  resize() {
    const w = Math.max(100, Math.floor(this.el.clientWidth));
    const h = Math.max(100, Math.floor(this.el.clientHeight));
    if (w !== this.u.width || h !== this.u.height) this.u.setSize({ width: w, height: h });
    if (this.last) this.update(this.last.p, this.last.cycles);
  }

  /** Show a GET /api/path answer; `cycles` is [[x...], [y...]] of per-cycle means or null. */
  update(p, cycles) {
    this.last = { p, cycles };
    const cols = (rows) => [rows.map((r) => r[1]), rows.map((r) => r[2])];
    const actual = cols(p.actual || []);
    const predicted = cols(p.predicted || []);
    const means = cycles || [[], []];
    this.u.batch(() => {
      this.u.setData([null, predicted, actual, means], false);
      const { x, y } = this.equalRanges([predicted, actual, means], p.anchor);
      this.u.setScale("x", x);
      this.u.setScale("y", y);
    });
  }

  /** The scales and the plotting area in CSS pixels (what maps a point to the screen), and how
   *  many canvas pixel columns the area has. */
  view() {
    const u = this.u;
    const r = uPlot.pxRatio;
    const { left, top, width, height } = u.bbox;
    return {
      x: [u.scales.x.min, u.scales.x.max],
      y: [u.scales.y.min, u.scales.y.max],
      box: { left: left / r, top: top / r, width: width / r, height: height / r },
      columns: width,
    };
  }

  /** Ranges around everything drawn, with the same metres per pixel on both axes. */
  equalRanges(sets, anchor) {
    let [xmin, xmax, ymin, ymax] = [Infinity, -Infinity, Infinity, -Infinity];
    const take = (x, y) => {
      xmin = Math.min(xmin, x);
      xmax = Math.max(xmax, x);
      ymin = Math.min(ymin, y);
      ymax = Math.max(ymax, y);
    };
    for (const [xs, ys] of sets) xs.forEach((x, i) => take(x, ys[i]));
    if (anchor) take(anchor.x_m, anchor.y_m);
    if (!Number.isFinite(xmin)) take(0, 0);
    const pw = Math.max(1, this.u.bbox.width);
    const ph = Math.max(1, this.u.bbox.height);
    const span = Math.max(MIN_SPAN_M, (xmax - xmin) * 1.15, ((ymax - ymin) * 1.15 * pw) / ph);
    const cx = (xmin + xmax) / 2;
    const cy = (ymin + ymax) / 2;
    const hy = ((span / pw) * ph) / 2;
    return { x: { min: cx - span / 2, max: cx + span / 2 }, y: { min: cy - hy, max: cy + hy } };
  }

  drawMarks(u) {
    const p = this.last?.p;
    if (!p) return;
    const ctx = u.ctx;
    const r = uPlot.pxRatio;
    const px = (x, y) => [u.valToPos(x, "x", true), u.valToPos(y, "y", true)];
    ctx.save();
    ctx.beginPath();
    ctx.rect(u.bbox.left, u.bbox.top, u.bbox.width, u.bbox.height);
    ctx.clip();
    if (p.anchor) {
      const [ax, ay] = px(p.anchor.x_m, p.anchor.y_m);
      ctx.strokeStyle = COLORS.anchor;
      ctx.lineWidth = 1.5 * r;
      ctx.beginPath();
      ctx.arc(ax, ay, 6 * r, 0, 2 * Math.PI);
      ctx.moveTo(ax, ay);
      ctx.lineTo(ax + 18 * r * Math.cos(p.anchor.yaw_rad), ay - 18 * r * Math.sin(p.anchor.yaw_rad));
      ctx.stroke();
    }
    const cur = p.actual?.length ? p.actual[p.actual.length - 1] : null;
    if (cur) {
      const [rx, ry] = px(cur[1], cur[2]);
      ctx.translate(rx, ry);
      ctx.rotate(-cur[3]); // yaw is counter-clockwise, the canvas y axis points down
      ctx.scale(r, r);
      ctx.fillStyle = COLORS.robot;
      ctx.strokeStyle = "#000";
      ctx.lineWidth = 1;
      ctx.beginPath();
      ctx.moveTo(11, 0);
      ctx.lineTo(-7, 6.5);
      ctx.lineTo(-4, 0);
      ctx.lineTo(-7, -6.5);
      ctx.closePath();
      ctx.fill();
      ctx.stroke();
    }
    ctx.restore();
  }
}

/** A uPlot path builder for a facet series (mode 2): one line through every point in the order
 *  of the data, never merged per pixel column, so a path that turns back on itself is drawn as
 *  it was walked. Points that are not finite break the line. */
export function inOrder(u, seriesIdx) {
  const [xs, ys] = u.data[seriesIdx];
  const stroke = new Path2D();
  let drawing = false;
  for (let i = 0; i < xs.length; i++) {
    const x = u.valToPos(xs[i], "x", true);
    const y = u.valToPos(ys[i], "y", true);
    if (!Number.isFinite(x) || !Number.isFinite(y)) {
      drawing = false;
    } else if (drawing) {
      stroke.lineTo(x, y);
    } else {
      stroke.moveTo(x, y);
      drawing = true;
    }
  }
  return { stroke, fill: null, clip: null, band: null, gaps: null, flags: 1 };
}

/** Mean (x, y) of each whole gait cycle of the actual path: [[x...], [y...]]. */
export function cycleMeans(rows, freqHz) {
  const xs = [];
  const ys = [];
  if (!rows?.length || !(freqHz > 0)) return [xs, ys];
  const t0 = rows[0][0];
  const tEnd = rows[rows.length - 1][0];
  let k = 0;
  let sx = 0;
  let sy = 0;
  let n = 0;
  for (const [t, x, y] of rows) {
    const c = Math.floor((t - t0) * freqHz);
    if (c !== k) {
      if (n) xs.push(sx / n), ys.push(sy / n);
      [k, sx, sy, n] = [c, 0, 0, 0];
    }
    if ((c + 1) / freqHz + t0 > tEnd + 1e-9) break; // the cycle in progress is not whole yet
    sx += x;
    sy += y;
    n++;
  }
  return [xs, ys];
}
