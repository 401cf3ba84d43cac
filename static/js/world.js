// The World panel: the model variation the live robot walks in (GET/PUT/DELETE /api/world), and
// the robustness job (POST /api/jobs/robustness): the current gait on N variations, its pass share
// per case drawn as bars with the 95 % interval, the worst variations each with a button that
// loads it into the live simulation, so the gait can be watched failing and tuned there.

import { api, formatDetail, poll } from "./api.js";
import { showRobot } from "./robot.js";
import { $, fmt, h, setMessage } from "./util.js";

const FIELDS = [
  ["friction", "floor friction", 2, ""],
  ["trunk_mass_scale", "trunk mass ×", 2, ""],
  ["link_mass_scale", "link masses ×", 2, ""],
  ["kp_scale", "servo kp ×", 2, ""],
  ["torque_scale", "servo torque ×", 2, ""],
  ["damping_scale", "joint damping ×", 2, ""],
  ["frictionloss_scale", "friction loss ×", 2, ""],
  ["latency_ms", "latency", 0, "ms"],
  ["deadband_deg", "dead band", 2, "°"],
  ["backlash_deg", "backlash", 2, "°"],
  ["tilt_deg", "floor tilt", 1, "°"],
  ["tilt_direction_deg", "downhill towards", 0, "° (0 ahead)"],
  // the sensors' errors (the laws read the sensors through them)
  ["imu_tilt_bias_deg", "IMU tilt bias", 2, "°"],
  ["imu_tilt_direction_deg", "IMU tilted towards", 0, "° (0 ahead)"],
  ["gyro_bias_deg_s", "gyro bias", 2, "°/s"],
  ["gyro_noise_deg_s", "gyro noise", 3, "°/s rms"],
  ["imu_delay_ms", "IMU delay", 0, "ms"],
  ["fsr_gain", "force sensor gain ×", 2, ""],
];
const NOMINAL = { friction: 0.7, tilt_direction_deg: 0, fsr_gain: 1 };
let job = null;

export function initWorld() {
  $("world-apply").addEventListener("click", () => apply(textFromSliders()));
  $("world-text-apply").addEventListener("click", () => apply($("world-text").value));
  $("world-nominal").addEventListener("click", nominal);
  $("robust-start").addEventListener("click", startRobustness);
  buildSliders();
  poll(refresh, 1000);
}

async function buildSliders() {
  const world = await api.get("/api/world");
  $("world-sliders").replaceChildren(
    ...FIELDS.map(([key, label, digits, unit]) => {
      const [lo, hi] = world.ranges[key];
      const value = world.values[key] ?? NOMINAL[key];
      const out = h("output", { id: `world-${key}-out` }, fmt(value, digits));
      const input = h("input", {
        type: "range", id: `world-${key}`, min: lo, max: hi, step: (hi - lo) / 100,
        "aria-label": label,
        oninput: (e) => (out.textContent = fmt(Number(e.target.value), digits)),
      });
      input.value = value; // after min, max and step: the browser fits a value to them
      return h("label", { class: "world-row", title: `default range ${lo}–${hi} ${unit}` },
        h("span", {}, label), input, out, h("span", { class: "dim small" }, unit));
    }),
  );
}

function textFromSliders() {
  const parts = [];
  for (const [key, , digits] of FIELDS) {
    const value = Number($(`world-${key}`).value);
    const nominal = NOMINAL[key] ?? (key.endsWith("_scale") ? 1 : 0);
    if (Math.abs(value - nominal) > 1e-9) parts.push(`${key}=${value.toFixed(Math.max(digits, 2))}`);
  }
  return parts.join(",");
}

async function apply(text) {
  try {
    const done = await api.put("/api/world", { variation: text.trim() });
    setMessage($("world-message"), `walking in: ${done.variation}`, "ok");
  } catch (err) {
    const why = Array.isArray(err.raw) && err.raw[0]?.msg ? err.raw[0].msg : err.message;
    setMessage($("world-message"), `not changed: ${why}`, "error");
  }
}

async function nominal() {
  await api.del("/api/world");
  await buildSliders();
  setMessage($("world-message"), "back on the nominal model", "ok");
}

async function refresh() {
  const state = await api.get("/api/state");
  const varied = state.world !== "nominal";
  const badge = $("world-badge");
  badge.hidden = !varied;
  badge.textContent = "world varied";
  badge.title = state.world;
  $("world-state").textContent = varied ? state.world : "nominal model";
  showRobot(state.robot);
  if (document.activeElement !== $("world-text")) $("world-text").value = varied ? state.world : "";
  if (job) await followJob();
}

async function startRobustness() {
  const samples = Number($("robust-samples").value);
  try {
    job = await api.post("/api/jobs/robustness", { samples });
    $("robust-progress").hidden = false;
    setMessage($("robust-message"), "walking the variations …");
  } catch (err) {
    setMessage($("robust-message"), formatDetail(err.raw) || err.message, "error");
  }
}

async function followJob() {
  const now = await api.get(`/api/jobs/${job.id}`);
  $("robust-progress").value = now.progress;
  if (now.status === "running") return;
  job = null;
  $("robust-progress").hidden = true;
  if (now.status === "failed") {
    setMessage($("robust-message"), `robustness failed: ${now.error}`, "error");
    return;
  }
  setMessage($("robust-message"), "", "");
  drawReport(now.result);
}

export function drawReport(result) {
  const report = result.presets[0];
  $("robust-title").textContent =
    `${report.preset} on ${result.samples} variations (seed ${result.seed}): ${(100 * report.overall_share).toFixed(0)} % of runs pass`;
  $("robust-bars").replaceChildren(
    ...report.cases.map((c) => {
      const [lo, hi] = c.interval;
      const pct = (x) => `${(100 * x).toFixed(1)}%`;
      const level = c.share >= 0.9 ? "ok" : c.share >= 0.6 ? "warn" : "bad";
      return h("div", { class: "robust-row", title: c.depends_on ? `failures depend on ${c.depends_on.parameter} (r ${c.depends_on.r.toFixed(2)})` : "" },
        h("span", { class: "robust-case" }, c.case),
        h("span", { class: "robust-track" },
          h("span", { class: `robust-bar ${level}`, style: `width:${pct(c.share)}` }),
          h("span", { class: "robust-ci", style: `left:${pct(lo)};width:${pct(hi - lo)}` })),
        h("span", { class: "robust-share" }, `${(100 * c.share).toFixed(0)} %`),
        h("span", { class: "dim small" }, c.depends_on ? c.depends_on.parameter : ""));
    }),
  );
  $("robust-worst").replaceChildren(
    ...report.worst.map((w) =>
      h("li", {},
        h("button", { type: "button", class: "small", onclick: () => watch(w) }, "Walk in it"),
        ` fails ${w.failed_cases}: ${w.failed.join(", ")} `,
        h("code", { class: "small dim" }, w.variation))),
  );
}

async function watch(worst) {
  const motion = worst.command.match(/--motion (\S+) --ca (\S+)/);
  await apply(worst.variation);
  if (motion) {
    const [a_r, a_p, a_y] = motion[1].split(",").map(Number);
    await api.patch("/api/params", { motion: { a_r, a_p, a_y, ca: Number(motion[2]) } });
  }
  await api.post("/api/sim/reset");
  setMessage($("world-message"), `walking ${worst.failed[0]} in the variation that failed it`, "ok");
}
