// Pure helpers that turn one scope frame (the /ws/scope JSON message) into drawable intervals.
// Times are in timer ticks from the frame start (0.5 µs per tick on ArtRo); a frame is
// `frame_ticks` long and split into 8 slots of `slot_ticks`.

/** Intervals [start, end) where a line given as (initial level, edges) is high, up to `endTick`. */
export function highIntervals(initial, edges, endTick) {
  const out = [];
  let level = initial;
  let since = 0;
  for (const [tick, next] of edges) {
    if (level === 1 && next === 0) out.push([since, tick]);
    if (next !== level) since = tick;
    level = next;
  }
  if (level === 1 && since < endTick) out.push([since, endTick]);
  return out;
}

/** Piecewise-constant value of the 3-bit select bus S2 S1 S0: [[start, end, value], ...].
 *  Every edge of any select line starts a new segment; the value is the bits read back. */
export function selectSegments(frame) {
  const end = frame.frame_ticks;
  const sel = ["S0", "S1", "S2"].map((n) => frame.lines.find((l) => l.name === n));
  if (sel.some((l) => !l)) return [[0, end, 0]];
  const ticks = new Set([0]);
  for (const line of sel) for (const [t] of line.edges) ticks.add(t);
  const starts = [...ticks].sort((a, b) => a - b);
  const levelAt = (line, t) => {
    let level = line.initial;
    for (const [tick, next] of line.edges) {
      if (tick > t) break;
      level = next;
    }
    return level;
  };
  const segs = [];
  starts.forEach((t0, i) => {
    const t1 = i + 1 < starts.length ? starts[i + 1] : end;
    const value = sel.reduce((acc, line, bit) => acc | (levelAt(line, t0) << bit), 0);
    // merge with the previous segment when the bus value did not change
    if (segs.length && segs[segs.length - 1][2] === value) segs[segs.length - 1][1] = t1;
    else segs.push([t0, t1, value]);
  });
  return segs;
}

/** Intersection of two sorted interval lists. */
function intersect(a, b) {
  const out = [];
  let i = 0;
  let j = 0;
  while (i < a.length && j < b.length) {
    const s = Math.max(a[i][0], b[j][0]);
    const e = Math.min(a[i][1], b[j][1]);
    if (e > s) out.push([s, e]);
    if (a[i][1] < b[j][1]) i++;
    else j++;
  }
  return out;
}

/** Where each servo sits: name -> {channel, slot, info} with `info` the frame's slot record. */
export function servoMap(frame) {
  const map = new Map();
  for (const ch of frame.channels) {
    for (const s of ch.slots) if (s.servo) map.set(s.servo, { channel: ch.name, slot: s.slot, info: s });
  }
  return map;
}

/** What demultiplexer output `slot` of TDM line `channel` carries: that line AND (select == slot),
 *  computed from the edges exactly as the hardware would (a pulse cut by an early select change,
 *  or spilling into the next output, shows up as it would on a real scope). */
export function demuxOutput(frame, channel, slot, selSegs = selectSegments(frame)) {
  const line = frame.lines.find((l) => l.name === channel);
  if (!line) return [];
  const high = highIntervals(line.initial, line.edges, frame.frame_ticks);
  const selected = selSegs.filter((s) => s[2] === slot).map(([s, e]) => [s, e]);
  return intersect(high, selected);
}
