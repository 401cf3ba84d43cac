// The scope's "Cycle" view, drawn by uPlot: each chosen servo folded over the gait phase 0-1
// (cycle-fold.js), its mean as a line and mean +- one standard deviation as a band; right-leg
// servos dashed and shifted by half a cycle, so each joint's left and right lie over each other.

import { foldCycles } from "./cycle-fold.js";
import { UPLOT_AXIS } from "./scope-theme.js";
import { SERVOS, servoColor } from "./util.js";

const uPlot = window.uPlot;
const REDRAW_MS = 250; // a fold of the last cycles changes slowly: 4 redraws a second are plenty

export class CyclePlot {
  constructor(el, infoEl) {
    this.el = el;
    this.infoEl = infoEl;
    this.shape = "";
    this.drawnAt = 0;
    this.u = null;
    new ResizeObserver(() => this.resize()).observe(el);
  }

  build(idx, key) {
    this.u?.destroy();
    const axis = UPLOT_AXIS;
    const series = [{}];
    const bands = [];
    for (const i of idx) {
      const color = servoColor(SERVOS[i]);
      const dash = SERVOS[i].startsWith("r_") ? [6, 4] : undefined;
      const base = series.length;
      series.push({ label: SERVOS[i], stroke: color, width: 1.8, dash, points: { show: false } });
      series.push({ label: `${SERVOS[i]} +sd`, stroke: "transparent", points: { show: false } });
      series.push({ label: `${SERVOS[i]} -sd`, stroke: "transparent", points: { show: false } });
      bands.push({ series: [base + 1, base + 2], fill: `${color}33` });
    }
    this.u = new uPlot(
      {
        width: Math.max(100, this.el.clientWidth),
        height: Math.max(100, this.el.clientHeight),
        legend: { show: false },
        cursor: { drag: { x: false, y: false }, points: { show: false } },
        scales: { x: { time: false, range: () => [0, 1] } },
        axes: [
          { ...axis, label: "gait phase (0 = φ_Trunk −π); right leg shifted by ½", size: 30, labelSize: 12 },
          { ...axis, label: key === "us" ? "pulse width (µs)" : "angle (°)", size: 52, labelSize: 12 },
        ],
        series,
        bands,
      },
      [[]],
      this.el,
    );
  }

  resize() {
    if (!this.u || !this.el.clientWidth) return;
    const w = Math.floor(this.el.clientWidth);
    const h = Math.floor(this.el.clientHeight);
    if (w !== this.u.width || h !== this.u.height) this.u.setSize({ width: w, height: h });
  }

  /** samples: RollBuffer.toArray(); opts: {servos, unit}. */
  update(samples, opts, force = false) {
    const idx = opts.servos.map((n) => SERVOS.indexOf(n)).filter((i) => i >= 0);
    const key = opts.unit === "deg" ? "deg" : "us";
    const shape = `${idx.join(",")}|${key}`;
    const now = performance.now();
    if (shape !== this.shape || !this.u) {
      this.shape = shape;
      this.build(idx, key);
      force = true;
    }
    if (!force && now - this.drawnAt < REDRAW_MS) return;
    this.drawnAt = now;
    this.resize();
    const fold = foldCycles(samples, idx, key);
    this.u.setData([fold.x, ...fold.series.flatMap((s) => [s.mean, s.hi, s.lo])]);
    const legend = idx.map((i) => {
      const item = document.createElement("span");
      item.className = `roll-legend-item${SERVOS[i].startsWith("r_") ? " dashed" : ""}`;
      item.style.setProperty("--c", servoColor(SERVOS[i]));
      item.textContent = SERVOS[i];
      return item;
    });
    const what = `${fold.cycles} whole cycle${fold.cycles === 1 ? "" : "s"} folded (the last ${samples.length} frames): mean ± 1 standard deviation;`;
    this.infoEl.replaceChildren(what, ...legend);
    window.artro = window.artro || {};
    window.artro.cycle = {
      cycles: fold.cycles,
      unit: key,
      means: Object.fromEntries(idx.map((i, k) => [SERVOS[i], fold.series[k].mean])),
    };
  }
}
