// Folding the roll buffer's samples over the gait cycle: each chosen servo's pulse width or angle
// against the trunk phase 0-1 (phi_Trunk from -pi to pi, docs/DESIGN.md §4), as the mean and the
// mean +- one standard deviation per phase bin over the cycles in the buffer. A right-leg servo is
// shifted by half a cycle (phi_R = phi_Trunk - pi/2 against phi_L = phi_Trunk + pi/2), so that
// left and right lie over each other when the gait is symmetric.

import { SERVOS } from "./util.js";

export const BINS = 50;

/** samples: RollBuffer.toArray(); idx: servo indices; key: "us" | "deg". */
export function foldCycles(samples, idx, key, bins = BINS) {
  const x = Array.from({ length: bins }, (_, b) => (b + 0.5) / bins);
  const sums = idx.map(() => ({ n: new Float64Array(bins), s: new Float64Array(bins), q: new Float64Array(bins) }));
  let wraps = 0;
  for (let j = 0; j < samples.length; j++) {
    const smp = samples[j];
    if (j && smp.phase < samples[j - 1].phase - Math.PI) wraps++;
    const p = (smp.phase + Math.PI) / (2 * Math.PI);
    idx.forEach((i, k) => {
      const v = smp[key][i];
      if (!Number.isFinite(v)) return;
      const shifted = SERVOS[i].startsWith("r_") ? (p + 0.5) % 1 : p;
      const b = Math.min(bins - 1, Math.max(0, Math.floor(shifted * bins)));
      sums[k].n[b]++;
      sums[k].s[b] += v;
      sums[k].q[b] += v * v;
    });
  }
  const series = sums.map(({ n, s, q }) => {
    const mean = [];
    const lo = [];
    const hi = [];
    for (let b = 0; b < bins; b++) {
      if (!n[b]) {
        mean.push(null), lo.push(null), hi.push(null);
        continue;
      }
      const m = s[b] / n[b];
      const sd = Math.sqrt(Math.max(0, q[b] / n[b] - m * m));
      mean.push(m), lo.push(m - sd), hi.push(m + sd);
    }
    return { mean, lo, hi };
  });
  return { x, series, cycles: wraps };
}
