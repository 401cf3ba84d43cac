// The Mega board's single-frame view (docs/BOARDS.md): the slots named by what the Mega does in
// them (the frame's `slots`), a lane of the PCA9685's own clock (where its period began: its
// oscillator is not the MCU's), the chosen servos' channels of PWM0..11
// drawn as the TDM scope draws servo pulses, then a lane of the I²C bus where each transaction is a
// box in time, as a logic analyser shows bus traffic (scope-bus.js shows a servo bus's write the
// same way): from its START to its end at 400 kHz, labelled with the part, address, register and
// bytes. Times are µs from the frame start (the frame's `pca9685` and `i2c`, app/firmware/mega_pulses.py).

import { drawCursors, frameAxis, GUTTER } from "./scope-axis.js";
import { THEME } from "./scope-theme.js";
import { busBox } from "./scope-trace.js";
import { servoColor, shortServo } from "./util.js";

const TOP = 34; // the slots' numbers and, under them, what the Mega does in each
const AXIS = 30;
const GAP = 8;
const MIN = { clock: 18, pwm: 22, i2c: 48 };
const MAX_SCALE = 1.8;
const PART_COLOR = { PCA9685: "#f2d04b", "MPU-6050": "#45c8e0" };
const PCA_CLOCK = "#c9a0ff";
const hex = (v) => `0x${v.toString(16).padStart(2, "0")}`;

/** Height in CSS px the Mega frame's view needs with `nServos` channel lanes. */
export function megaFrameMinHeight(frame, nServos) {
  return TOP + AXIS + 3 * GAP + MIN.clock + nServos * MIN.pwm + MIN.i2c;
}

/** The channels of the chosen servos (the scope's servo check boxes), in channel order. */
export function chosenChannels(frame, servos) {
  const chosen = new Set(servos);
  return frame.pca9685.channels.filter((c) => chosen.has(c.servo));
}

/** The wordings of what the Mega does in a slot (its header's second line), longest first. */
export function taskWords(task) {
  return [task, task.split(" ")[0]];
}

/** What the PCA9685 clock lane says of a period begun at `startUs` in the frame. */
export function periodWords(pca, startUs) {
  const slip = pca.slip_us_per_frame;
  const at = `${(startUs / 1000).toFixed(3)} ms`;
  const drift = `${Math.abs(slip).toFixed(1)} µs ${slip < 0 ? "earlier" : "later"} each frame`;
  return [
    `PCA9685 period begins at ${at}: its own oscillator (${(pca.period_us / 1000).toFixed(3)} ms ` +
      `a period) begins it ${drift}, not at the MCU's frame`,
    `period begins ${at}: own oscillator, ${drift}`,
    `period ${at} (own oscillator)`,
  ];
}

/** The wordings of a transaction's label, longest first. */
export function i2cLabels(t) {
  const dir = t.write ? (t.restarts ? "W+R" : "W") : "R"; // W+R: a register read
  const reg = t.register == null ? "" : ` reg ${hex(t.register)}`;
  return [
    `${t.part} ${hex(t.address)} ${dir}${reg} · ${t.bytes} B`,
    `${hex(t.address)}${reg} · ${t.bytes} B`,
    `${hex(t.address)}${reg}`,
    hex(t.address),
  ];
}

function lanes(frame, servos, h) {
  const items = [{ kind: "clock" }, ...chosenChannels(frame, servos).map((c) => ({ kind: "pwm", c }))];
  items.push({ kind: "i2c" });
  const minSum = items.reduce((a, it) => a + MIN[it.kind], 0);
  const scale = Math.min(MAX_SCALE, Math.max(1, (h - TOP - AXIS - 3 * GAP) / minSum));
  let y = TOP + GAP;
  for (const it of items) {
    if (it.kind === "i2c") y += GAP;
    it.y = y;
    it.h = MIN[it.kind] * scale;
    y += it.h;
  }
  return items;
}

/** High spans [start, end] in µs of a channel given as its level at 0 and its edges. */
function highSpans(c, endUs) {
  const out = [];
  let level = c.initial;
  let since = 0;
  for (const [t, next] of c.edges_us) {
    if (level === 1 && next === 0) out.push([since, t]);
    if (next !== level) since = t;
    level = next;
  }
  if (level === 1) out.push([since, endUs]);
  return out;
}

function gridAndAxis(ctx, ax, frame, frameUs, slotUs, top, bottom) {
  const tasks = new Map((frame.slots ?? []).map((s) => [s.slot, s.task]));
  const headers = [];
  ctx.lineWidth = 1;
  for (let us = 0; us <= frameUs + 1e-6; us += 500) {
    ctx.strokeStyle = us % 2000 === 0 ? THEME.gridMajor : THEME.gridMinor;
    const x = Math.round(ax.toX(us)) + 0.5;
    ctx.beginPath();
    ctx.moveTo(x, top);
    ctx.lineTo(x, bottom);
    ctx.stroke();
  }
  ctx.setLineDash([4, 4]);
  ctx.strokeStyle = THEME.slotLine;
  ctx.font = THEME.font;
  ctx.textAlign = "center";
  ctx.textBaseline = "middle";
  for (let k = 0; k * slotUs <= frameUs + 1e-6; k++) {
    const x = Math.round(ax.toX(k * slotUs)) + 0.5;
    ctx.beginPath();
    ctx.moveTo(x, top - 30);
    ctx.lineTo(x, bottom);
    ctx.stroke();
    if ((k + 1) * slotUs <= frameUs + 1e-6) {
      const task = tasks.get(k);
      const mid = ax.toX((k + 0.5) * slotUs);
      ctx.font = THEME.font;
      ctx.fillStyle = task ? THEME.text : THEME.dim;
      ctx.fillText(`slot ${k}`, mid, top - 22);
      let header = `slot ${k}`;
      if (task) {
        ctx.font = THEME.small;
        const room = ax.toX(slotUs) - ax.x0 - 6;
        const words = taskWords(task);
        const said = words.find((t) => ctx.measureText(t).width < room) ?? words[words.length - 1];
        ctx.fillStyle = PART_COLOR[said.split(" ")[0]] ?? THEME.select;
        ctx.fillText(said, mid, top - 9);
        header += ` · ${said}`;
      }
      headers.push(header);
    }
  }
  ctx.canvas.dataset.slotLabels = JSON.stringify(headers);
  ctx.setLineDash([]);
  ctx.strokeStyle = THEME.text;
  ctx.fillStyle = THEME.text;
  ctx.textBaseline = "top";
  for (let us = 0; us <= frameUs + 1e-6; us += 2500) {
    const x = Math.round(ax.toX(us)) + 0.5;
    ctx.beginPath();
    ctx.moveTo(x, bottom + 4);
    ctx.lineTo(x, bottom + 10);
    ctx.stroke();
    ctx.textAlign = us === 0 ? "left" : us >= frameUs ? "right" : "center";
    ctx.fillText(`${(us / 1000).toFixed(1)}`, x, bottom + 12);
  }
  ctx.textAlign = "left";
  ctx.fillStyle = THEME.dim;
  ctx.fillText("ms", ax.x0 - 40, bottom + 12);
}

/** The PCA9685's clock lane: a marker where each of its periods began in the frame, said to be
 *  its own oscillator's (it slips against the MCU's 20 ms frame). Returns the labels drawn. */
function drawClock(ctx, lane, ax, pca, bottom) {
  ctx.textAlign = "left";
  ctx.textBaseline = "top";
  ctx.font = `bold ${THEME.small}`;
  ctx.fillStyle = PCA_CLOCK;
  ctx.fillText("PCA clock", 8, lane.y + 3);
  const shown = [];
  for (const startUs of pca.period_starts_us ?? []) {
    const x = Math.round(ax.toX(startUs)) + 0.5;
    ctx.strokeStyle = PCA_CLOCK;
    ctx.lineWidth = 1;
    ctx.setLineDash([2, 3]);
    ctx.beginPath();
    ctx.moveTo(x, lane.y + 2);
    ctx.lineTo(x, bottom);
    ctx.stroke();
    ctx.setLineDash([]);
    ctx.fillStyle = PCA_CLOCK;
    ctx.beginPath();
    ctx.moveTo(x - 4, lane.y + 2);
    ctx.lineTo(x + 4, lane.y + 2);
    ctx.lineTo(x, lane.y + 8);
    ctx.fill();
    ctx.font = THEME.small;
    const words = periodWords(pca, startUs);
    const right = ax.x1 - x >= x - ax.x0; // the label on the side with more room
    const room = (right ? ax.x1 - x : x - ax.x0) - 8;
    const label = words.find((t) => ctx.measureText(t).width < room) ?? words[words.length - 1];
    ctx.textAlign = right ? "left" : "right";
    ctx.fillText(label, right ? x + 6 : x - 6, lane.y + 3);
    shown.push(label);
  }
  return shown;
}

function drawChannel(ctx, lane, ax, frameUs) {
  const { c } = lane;
  const color = servoColor(c.servo);
  ctx.textAlign = "left";
  ctx.textBaseline = "top";
  ctx.font = `bold ${THEME.small}`;
  ctx.fillStyle = THEME.tdm;
  ctx.fillText(c.name, 8, lane.y + 3);
  ctx.fillStyle = color;
  ctx.font = THEME.small;
  ctx.fillText(shortServo(c.servo), 8 + ctx.measureText(`${c.name}  `).width, lane.y + 3);
  const hi = lane.y + 4;
  const lo = lane.y + lane.h - 4;
  const spans = highSpans(c, frameUs);
  ctx.beginPath();
  ctx.moveTo(ax.x0, lo);
  for (const [s, e] of spans) {
    ctx.lineTo(ax.toX(s), lo);
    ctx.lineTo(ax.toX(s), hi);
    ctx.lineTo(ax.toX(e), hi);
    ctx.lineTo(ax.toX(e), lo);
  }
  ctx.lineTo(ax.x1, lo);
  ctx.strokeStyle = color;
  ctx.lineWidth = 1.5;
  ctx.stroke();
  ctx.fillStyle = `${color}22`;
  for (const [s, e] of spans) ctx.fillRect(ax.toX(s), hi, ax.toX(e) - ax.toX(s), lo - hi);
  if (c.pulse_us != null) {
    ctx.fillStyle = THEME.text;
    ctx.textAlign = "right";
    ctx.textBaseline = "middle";
    ctx.fillText(`${c.pulse_us.toFixed(1)}µs`, GUTTER - 6, (hi + lo) / 2 + 5);
  }
}

/** The I²C lane: each transaction a box from its START to its end on a 400 kHz bus, its label
 *  under it (the longest wording that fits before the next box). Returns the labels drawn. */
function drawI2c(ctx, lane, ax, i2c) {
  ctx.textAlign = "left";
  ctx.textBaseline = "top";
  ctx.font = `bold ${THEME.font}`;
  ctx.fillStyle = THEME.select;
  ctx.fillText("I²C", 8, lane.y + 3);
  ctx.font = THEME.small;
  ctx.fillStyle = THEME.dim;
  ctx.fillText(`${(i2c.bus_hz / 1000).toFixed(0)} kHz`, 8, lane.y + 17);
  ctx.fillText(`${(i2c.bus_us / 1000).toFixed(2)} ms busy`, 8, lane.y + 29);
  const top = lane.y + 4;
  const bot = top + Math.min(20, lane.h * 0.45);
  const mid = (top + bot) / 2;
  ctx.strokeStyle = THEME.gridMajor;
  ctx.beginPath();
  ctx.moveTo(ax.x0, mid + 0.5);
  ctx.lineTo(ax.x1, mid + 0.5);
  ctx.stroke();
  const boxes = i2c.transactions
    .map((t) => ({ t, xs: Math.max(ax.x0, ax.toX(t.start_us)), xe: Math.min(ax.x1, ax.toX(t.end_us)) }))
    .filter((b) => b.xe > b.xs);
  const shown = [];
  boxes.forEach(({ t, xs, xe }, i) => {
    const color = t.acked ? PART_COLOR[t.part] ?? THEME.text : THEME.guard;
    const bevel = Math.min(4, (xe - xs) / 3);
    ctx.fillStyle = `${color}30`;
    ctx.strokeStyle = color;
    ctx.lineWidth = 1.4;
    busBox(ctx, xs, xe, top, mid, bot, bevel);
    ctx.fill();
    ctx.stroke();
    ctx.font = THEME.small;
    const room = (i + 1 < boxes.length ? boxes[i + 1].xs : ax.x1) - xs - 6;
    const words = i2cLabels(t);
    const label = words.find((s) => ctx.measureText(s).width < room) ?? words[words.length - 1];
    ctx.fillStyle = color;
    ctx.textAlign = "left";
    ctx.textBaseline = "top";
    ctx.fillText(label, xs, bot + 4);
    shown.push(label);
  });
  return shown;
}

/** Draw one Mega frame; opts as drawSingleFrame's ({servos, cursors}): the chosen servos'
 *  channels. Returns the x axis. */
export function drawMegaFrame(ctx, w, h, frame, opts) {
  ctx.fillStyle = THEME.bg;
  ctx.fillRect(0, 0, w, h);
  const frameUs = frame.frame_ticks * frame.tick_us;
  const slotUs = frame.slot_ticks * frame.tick_us;
  const ax = frameAxis(w, frameUs);
  const ls = lanes(frame, opts.servos ?? [], h);
  const last = ls[ls.length - 1];
  const bottom = last.y + last.h;
  gridAndAxis(ctx, ax, frame, frameUs, slotUs, TOP, bottom);
  let shown = [];
  let clock = [];
  for (const lane of ls) {
    if (lane.kind === "pwm") drawChannel(ctx, lane, ax, frameUs);
    else if (lane.kind === "clock") clock = drawClock(ctx, lane, ax, frame.pca9685, bottom);
    else shown = drawI2c(ctx, lane, ax, frame.i2c);
  }
  // what the lanes say, for a reader that cannot see the canvas (the tests)
  ctx.canvas.dataset.i2cBoxes = JSON.stringify(shown);
  ctx.canvas.dataset.pwmLanes = JSON.stringify(ls.filter((l) => l.kind === "pwm").map((l) => l.c.name));
  ctx.canvas.dataset.pcaPeriods = JSON.stringify(clock);
  drawCursors(ctx, ax.toX, opts.cursors, TOP, bottom, [ax.x0, ax.x1]);
  return ax;
}
