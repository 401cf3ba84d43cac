// The Sensors panel: what the modelled IMU and sole force sensors read and what the feedback
// laws made of it (GET /api/sensors, the last 5 s, five times a second), drawn by uPlot in the
// charts the server declares (GET /api/sensors/channels: the estimated against the true trunk
// pitch and roll, the gyro, each law's output) -- and each sole's centre of pressure drawn in its
// outline, while the panel is on screen; and the Push control (POST /api/sim/push, button or the
// P key), the push then drawn in the 3D view. While `artro link` forwards a real
// robot's frames (the view's `robot`), the series the server declares for it (the channels'
// `robot`: its attitude, gyro and tilt trim) are drawn beside the simulation's ("robot: ...",
// the simulation's "sim: ..."), its last frame placed where it arrived, and a line says how its
// IMU is; no robot, nothing extra.

import { api, poll } from "./api.js";
import { THEME, UPLOT_AXIS } from "./scope-theme.js";
import { $, fieldNumber, fieldRule, fitCanvas, fmt, setMessage } from "./util.js";

const uPlot = window.uPlot;
// the laws ([group, name], in switch-bit order) and the charts with their series, as the server
// declares them once (GET /api/sensors/channels, app/sim/sensor_channels.py): asked once
let LAWS = [];
// the charts' boxes in the page; a chart without one gets a box after the last
const PLOT_BOXES = { attitude: "sensors-attitude", gyro: "sensors-gyro", laws: "sensors-laws-plot" };
const FEET = [
  ["l", "left", "#4dabf7"],
  ["r", "right", "#ff922b"],
];
const COP_TRAIL_FRAMES = 50; // the last second of each sole's centre of pressure
const PLOT_HEIGHT = 190; // px, the legend below

const plots = {};
let latest = null;
let fallen = false; // the robot lies fallen: a push waits for a reset (the server refuses it)

export function initSensors() {
  $("push-button").addEventListener("click", push);
  document.addEventListener("artro:state", (e) => (fallen = Boolean(e.detail.fell)));
  document.addEventListener("keydown", (e) => {
    const typing = e.target.closest?.("input, select, textarea, [contenteditable]");
    if ((e.key === "p" || e.key === "P") && !typing && !e.ctrlKey && !e.metaKey && !e.altKey) {
      e.preventDefault();
      push();
    }
  });
  new ResizeObserver(() => drawCop()).observe($("sensors-cop"));
  // fetched and drawn only while the panel is on screen: the page's other views keep the time
  new IntersectionObserver(([entry]) => (onScreen = entry.isIntersecting)).observe($("sensors-panel"));
  poll(refresh, 200);
}

let onScreen = false;

/** A chart per declared chart, each drawing the channels declared on it, in their order. */
function buildPlots(declared) {
  LAWS = declared.laws.map(({ group, label }) => [group, label]);
  for (const chart of declared.charts) {
    const series = declared.channels
      .filter((c) => c.chart === chart.key)
      .map((c) => [c.key, c.label, c.colour, c.dashed ? [4, 4] : undefined, c.scale === 1 ? undefined : c.scale]);
    const spec = { label: chart.label, series };
    // the robot's series: [column, label, colour] (drawn thicker, in a lighter tint)
    const robot = (declared.robot[chart.key] ?? []).map((r) => [r.key, `robot: ${r.label}`, r.colour]);
    plots[chart.key] = new SensorPlot(plotBox(chart.key), spec, robot);
  }
}

function plotBox(chart) {
  const id = PLOT_BOXES[chart] ?? `sensors-${chart}`;
  if ($(id)) return $(id);
  const last = Object.values(plots).at(-1)?.el ?? $(PLOT_BOXES.laws);
  const box = Object.assign(document.createElement("div"), { className: "sensors-plot", id });
  last.after(box);
  return box;
}

async function refresh() {
  if (!onScreen || document.hidden) return;
  if (!LAWS.length) buildPlots(await api.get("/api/sensors/channels"));
  const [view, params] = await Promise.all([api.get("/api/sensors"), lawsOn()]);
  latest = view;
  const robot = view.robot ? robotOnSimTime(view) : null;
  for (const plot of Object.values(plots)) plot.update(view.columns, robot);
  showRobot(view.robot);
  drawCop();
  const on = LAWS.filter(([key]) => params[key]).map(([, label]) => label);
  $("sensors-laws").textContent = on.length ? `laws on: ${on.join(", ")}` : "every law off (open loop)";
}

let paramsCache = { at: 0, laws: {} };
async function lawsOn() {
  if (performance.now() - paramsCache.at > 1000) {
    const p = await api.get("/api/params");
    paramsCache = { at: performance.now(), laws: Object.fromEntries(LAWS.map(([k]) => [k, !!p.gait[k]?.enabled])) };
  }
  return paramsCache.laws;
}

/** The robot's columns with `t_s` on the simulation's axis: its last frame where it arrived
 * (the simulation's last row less the time since), the others its own 20 ms steps before. */
function robotOnSimTime(view) {
  const cols = view.robot.columns;
  const simT = view.columns.t_s;
  const own = cols.t_s;
  if (!simT.length || !own.length) return cols;
  const end = simT[simT.length - 1] - view.robot.received_s_ago;
  const last = own[own.length - 1];
  return { ...cols, t_s: own.map((t) => end - (last - t)) };
}

/** One line on the linked robot: its IMU, the failed reads, its last frame; hidden without. */
function showRobot(robot) {
  const el = $("sensors-robot");
  el.hidden = !robot;
  if (!robot) return;
  const status = new Set(robot.status);
  let imu = "IMU ok";
  if (!status.has("imu_present")) imu = "no IMU (no answer at boot)";
  else if (status.has("imu_stale")) {
    const why = status.has("imu_nack") ? ": no acknowledge" : status.has("imu_short") ? ": bus error" : "";
    imu = `IMU stale${why}`;
  }
  const parts = [`robot: ${imu}`];
  if (status.has("fsr_stale")) parts.push("foot sensors stale");
  const failures = robot.imu_failures >= 255 ? "≥ 255" : String(robot.imu_failures);
  parts.push(`${failures} IMU failure${robot.imu_failures === 1 ? "" : "s"}`);
  const laws = LAWS.filter(([key]) => robot.laws.includes(key)).map(([, label]) => label);
  parts.push(laws.length ? `laws on: ${laws.join(", ")}` : "every law off");
  parts.push(`frame ${robot.frame}`);
  if (robot.received_s_ago > 0.5) parts.push(`${fmt(robot.received_s_ago, 1)} s ago`);
  el.textContent = parts.join(" · ");
  el.classList.toggle("robot-warn", imu !== "IMU ok" || status.has("fsr_stale"));
}

async function push() {
  const msg = $("push-message");
  const impulse = fieldNumber($("push-impulse"));
  const direction = fieldNumber($("push-direction"));
  if (impulse === null || direction === null) {
    const [what, field] = impulse === null ? ["impulse", $("push-impulse")] : ["toward", $("push-direction")];
    setMessage(msg, `no push: ${what} ${fieldRule(field)}`, "error");
    return;
  }
  if (fallen) {
    setMessage(msg, "no push: the robot has fallen; reset it first", "error");
    return;
  }
  try {
    await api.post("/api/sim/push", { impulse_n_s: impulse, direction_deg: direction });
    setMessage(msg, `pushed: ${fmt(impulse, 2)} N·s toward ${fmt(direction, 0)}°`, "ok");
  } catch (err) {
    // fallen since the last state: the next pushes wait here for a reset, not at the server
    if (err.status === 409 && err.raw?.[0]?.type === "fallen") fallen = true;
    setMessage(msg, `no push: ${err.message}`, "error");
  }
}

class SensorPlot {
  constructor(el, spec, robotSeries) {
    this.el = el;
    this.spec = spec;
    this.robotSeries = robotSeries;
    this.u = null;
    this.withRobot = false;
    new ResizeObserver(() => this.resize()).observe(el);
  }

  /** The plot with the simulation's series, and the robot's after them when it is linked. */
  build(withRobot) {
    this.u?.destroy();
    this.withRobot = withRobot;
    const sim = this.spec.series.map(([, label, stroke, dash]) => ({
      label: withRobot ? `sim: ${label}` : label,
      stroke,
      dash,
      width: 1.5,
      points: { show: false },
    }));
    const robot = withRobot
      ? this.robotSeries.map(([, label, stroke]) => ({ label, stroke, width: 2.5, points: { show: false } }))
      : [];
    const series = [{}, ...sim, ...robot];
    this.u = new uPlot(
      {
        width: Math.max(120, this.el.clientWidth),
        height: PLOT_HEIGHT,
        // a dashed series (the true tilt beside the estimate) gets a dashed swatch too
        legend: { show: true, live: false, markers: { dash: (u, i) => (u.series[i].dash ? "dashed" : "solid") } },
        cursor: { drag: { x: false, y: false }, points: { show: false } },
        scales: { x: { time: false } },
        axes: [
          { ...UPLOT_AXIS, label: "simulated time (s)", size: 30, labelSize: 12 },
          { ...UPLOT_AXIS, label: this.spec.label, size: 48, labelSize: 12 },
        ],
        series,
      },
      [[]],
      this.el,
    );
    this.resize();
  }

  update(columns, robot) {
    if (!this.u || this.withRobot !== !!robot) this.build(!!robot);
    const data = [columns.t_s, ...this.spec.series.map(([key, , , , scale]) => scaled(columns[key], scale))];
    if (!robot) {
      this.u.setData(data);
      return;
    }
    // two clocks on one axis: uPlot.join puts both tables on the union of their times, a
    // series without a point at a time is drawn across it
    const own = [robot.t_s, ...this.robotSeries.map(([key]) => robot[key])];
    this.u.setData(uPlot.join([data, own]));
  }

  /** The plot is as wide as its box; its height is fixed, the legend below it. */
  resize() {
    if (!this.u || !this.el.clientWidth) return;
    const width = Math.floor(this.el.clientWidth);
    if (width !== this.u.width) this.u.setSize({ width, height: PLOT_HEIGHT });
  }
}

const scaled = (values, scale) => (scale ? values.map((v) => (v == null ? null : v * scale)) : values);

/** Both soles from above (toes up), the force sensors as dots sized by their share, the centre
 * of pressure's last second as a trail. */
function drawCop() {
  const canvas = $("sensors-cop");
  const { ctx, w: width, h: height } = fitCanvas(canvas);
  ctx.clearRect(0, 0, width, height);
  if (!latest?.sole_mm) return;
  const [halfL, halfW] = latest.sole_mm;
  const scale = Math.min((height - 36) / (2 * halfL), (width - 30) / (4 * halfW + 40));
  const cols = latest.columns;
  const last = cols.t_s.length - 1;
  FEET.forEach(([side, label, color], i) => {
    const cx = width / 2 + (i === 0 ? -1 : 1) * (halfW * scale + 12); // left foot on the left
    const cy = height / 2 - 6;
    ctx.strokeStyle = THEME.text;
    ctx.lineWidth = 1;
    ctx.strokeRect(cx - halfW * scale, cy - halfL * scale, 2 * halfW * scale, 2 * halfL * scale);
    for (const [x, y] of latest.fsr_mm) {
      ctx.fillStyle = THEME.dim;
      ctx.beginPath();
      ctx.arc(cx - y * scale, cy - x * scale, 3, 0, 2 * Math.PI);
      ctx.fill();
    }
    const xs = cols[`cop_${side}_x_mm`];
    const ys = cols[`cop_${side}_y_mm`];
    ctx.strokeStyle = color;
    ctx.lineWidth = 1.5;
    ctx.beginPath();
    let pen = false;
    for (let k = Math.max(0, last - COP_TRAIL_FRAMES); k <= last; k++) {
      if (xs[k] == null) {
        pen = false;
        continue;
      }
      const px = cx - ys[k] * scale;
      const py = cy - xs[k] * scale;
      if (pen) ctx.lineTo(px, py);
      else ctx.moveTo(px, py);
      pen = true;
    }
    ctx.stroke();
    if (last >= 0 && xs[last] != null) {
      ctx.fillStyle = color;
      ctx.beginPath();
      ctx.arc(cx - ys[last] * scale, cy - xs[last] * scale, 5, 0, 2 * Math.PI);
      ctx.fill();
    }
    const load = last >= 0 ? cols[`load_${side}_n`][last] : null;
    ctx.fillStyle = THEME.text;
    ctx.font = THEME.small;
    ctx.textAlign = "center";
    ctx.fillText(`${label} ${load == null ? "—" : `${fmt(load, 1)} N`}`, cx, cy + halfL * scale + 16);
  });
}
