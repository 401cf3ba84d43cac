// The World panel: the model variation the live robot walks in (GET/PUT/DELETE /api/world), and
// the robustness job (POST /api/jobs/robustness): the current gait on N variations, its pass share
// per case drawn as bars with the 95 % interval, the worst variations each with a button that
// loads it into the live simulation, so the gait can be watched failing and tuned there. The
// sliders follow the live world (however it was set); Apply keeps the terms no slider shows
// (calibration, a push). The last report of the gait in use is kept by the server and drawn again
// on a reload (GET /api/world/robustness, when GET /api/state says there is one).

import { api, formatDetail, poll } from "./api.js";
import { showRobot } from "./robot.js";
import { $, aboutLeft, fieldNumber, fieldRule, fmt, h, hideKeepingFocus, setMessage } from "./util.js";

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
/** What a failure may depend on (app/analysis/robustness.py `features`) in the sliders' words and
 *  units: the sliders' own, and those no slider shows (issue 56, item 15). */
const FEATURES = {
  ...Object.fromEntries(FIELDS.map(([key, label, , unit]) => [key, [label, unit.split(" ")[0]]])),
  tilt_forward_deg: ["floor tilt, downhill ahead", "°"],
  tilt_sideways_deg: ["floor tilt, sideways", "°"],
  calibration_max_deg: ["largest joint calibration error", "°"],
  push_n_s: ["push", "N·s"],
  push_time_s: ["push at", "s"],
  push_direction_deg: ["push towards", "°"],
};

/** "latency (ms)", "trunk mass ×": a parameter as the World panel names it. */
export function featureLabel(key) {
  const [label, unit] = FEATURES[key] ?? [key, ""];
  return unit ? `${label} (${unit})` : label;
}

/** A case's "failures depend on" cell: the parameter in the panel's words, and whether the sample
 *  is large enough to trust the correlation (the server's `trusted`), with the numbers. */
function dependsOn(d) {
  if (!d) return [h("span", { class: "dim small" }, ""), ""];
  const label = featureLabel(d.parameter);
  const [, unit] = FEATURES[d.parameter] ?? [d.parameter, ""];
  const pct = (x) => `${Math.round(100 * x)} %`;
  const median = `${Number(d.median.toPrecision(3))}${unit && unit !== "×" ? ` ${unit}` : ""}`;
  const why =
    `failures depend most on ${label}: r ${d.r >= 0 ? "+" : ""}${d.r.toFixed(2)} over ${d.samples} ` +
    `variations, ${d.failing} failing; ${pct(d.fail_below)} fail at or below ${median}, ` +
    `${pct(d.fail_above)} above`;
  if (d.trusted) return [h("span", { class: "dim small" }, label), why];
  const doubt =
    `. Too small a sample to trust: a correlation this strong comes by chance with p ` +
    `${d.p_value.toFixed(2)} among the ${d.compared} parameters compared; it is trusted from ` +
    `p < 0.05 with at least 5 variations failing and 5 passing. Run more variations.`;
  return [
    h("span", { class: "dim small robust-doubt" }, `${label}? `, h("em", {}, "too few to trust")),
    why + doubt,
  ];
}
const SLIDER_KEYS = new Set(FIELDS.map(([key]) => key));
const CIRCULAR = new Set(["tilt_direction_deg", "imu_tilt_direction_deg", "push_direction_deg"]);
const EXTREME = 0.1; // a value in the outer tenth of its default range, away from nominal, is marked
let job = null;
let cancelling = false; // asked to stop: its progress line no longer shown
let ranges = {}; // the default ranges of `artro bench robust`, per field
let fittedBy = null; // whose fit the live world is (a fit job, the fitted robot), or null
let liveWorld = "nominal"; // the world the state last named
let reportTitle = ""; // the title of the report drawn ("" none)
let gaitShown = null; // the gait (as JSON) whose last report was asked for: a motion change keeps it
let textEdited = false; // the World text was typed in and not yet applied: the state keeps off it

export function initWorld() {
  $("world-apply").addEventListener("click", () => apply(textFromSliders()));
  $("world-text-apply").addEventListener("click", () => apply($("world-text").value));
  $("world-text").addEventListener("input", () => (textEdited = true));
  $("world-nominal").addEventListener("click", nominal);
  $("robust-start").addEventListener("click", startRobustness);
  $("robust-cancel").addEventListener("click", cancelRobustness);
  buildSliders();
  poll(refresh, 1000);
  document.addEventListener("artro:params", (e) => {
    const gait = JSON.stringify(e.detail.gait ?? null);
    if (gait === gaitShown) return; // only a new gait can have another report
    gaitShown = gait;
    showLastReport();
  });
}

async function buildSliders() {
  const world = await api.get("/api/world");
  ranges = world.ranges;
  liveWorld = world.variation;
  fittedBy = world.fitted;
  $("world-sliders").replaceChildren(
    ...FIELDS.map(([key, label, digits, unit]) => {
      const nominal = nominalOf(key);
      const [lo, hi] = [Math.min(world.ranges[key][0], nominal), Math.max(world.ranges[key][1], nominal)];
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

/** The sliders set to the live world's values (those not being dragged). */
async function followWorld() {
  const world = await api.get("/api/world");
  liveWorld = world.variation;
  fittedBy = world.fitted;
  for (const [key, , digits] of FIELDS) {
    const input = $(`world-${key}`);
    if (!input || document.activeElement === input) continue;
    const value = world.values[key] ?? NOMINAL[key];
    input.value = value;
    $(`world-${key}-out`).textContent = fmt(value, digits);
  }
}

/** The terms of a variation's text, as [key, value text]. */
const terms = (text) =>
  text === "nominal" || !text ? [] : text.split(",").map((t) => t.split("=").map((s) => s.trim()));

/** A field's value on the nominal model (a slider reaches it even outside the default range). */
const nominalOf = (key) => NOMINAL[key] ?? (key.endsWith("_scale") ? 1 : 0);

function textFromSliders() {
  const parts = [];
  for (const [key, , digits] of FIELDS) {
    const value = Number($(`world-${key}`).value);
    const nominal = nominalOf(key);
    if (Math.abs(value - nominal) > 1e-9) parts.push(`${key}=${value.toFixed(Math.max(digits, 2))}`);
  }
  // what no slider shows (each joint's calibration, a push) stays as the live world has it
  const kept = terms(liveWorld).filter(([key]) => !SLIDER_KEYS.has(key));
  return [...parts, ...kept.map(([key, value]) => `${key}=${value}`)].join(",");
}

/** The header's short word on the world: "nominal model" or the fields varied, first few named. */
function worldSummary(text) {
  const keys = terms(text).map(([key]) => (key.startsWith("cal.") ? "calibration" : key));
  const names = [...new Set(keys)];
  if (!names.length) return "nominal model";
  const shown = names.slice(0, 2).join(", ");
  return `varied: ${shown}${names.length > 2 ? ` +${names.length - 2} more` : ""}`;
}

async function apply(text) {
  try {
    const done = await api.put("/api/world", { variation: text.trim() });
    textEdited = false; // applied: the text follows the live world again
    setMessage($("world-message"), `walking in: ${done.variation}`, "ok");
  } catch (err) {
    const why = Array.isArray(err.raw) && err.raw[0]?.msg ? err.raw[0].msg : err.message;
    setMessage($("world-message"), `not changed: ${why}`, "error");
  }
}

async function nominal() {
  await api.del("/api/world");
  textEdited = false;
  await buildSliders();
  setMessage($("world-message"), "back on the nominal model", "ok");
}

async function refresh() {
  const state = await api.get("/api/state");
  const varied = state.world !== "nominal";
  const badge = $("world-badge");
  badge.hidden = !varied;
  badge.title = state.world;
  if (state.world !== liveWorld) await followWorld();
  // a fit in force says so: "fitted: <variation>" (docs/FIT.md, "On the dashboard")
  const fit = varied && fittedBy && state.world === liveWorld;
  $("world-state").textContent = fit ? `fitted: ${state.world}` : worldSummary(state.world);
  $("world-state").title = varied ? (fit ? `the fit of ${fittedBy}: ${state.world}` : state.world) : "";
  $("world-state").classList.toggle("fitted", Boolean(fit));
  badge.textContent = fit ? "fitted robot" : "world varied";
  showRobot(state.robot);
  // the text follows the live world, unless it is being typed or was refused: then it is kept
  if (document.activeElement !== $("world-text") && !textEdited) {
    $("world-text").value = varied ? state.world : "";
  }
  if (job) await followJob();
}

async function startRobustness() {
  const samples = fieldNumber($("robust-samples"));
  if (samples === null) {
    setMessage($("robust-message"), `not started: variations ${fieldRule($("robust-samples"))}`, "error");
    return;
  }
  try {
    job = await api.post("/api/jobs/robustness", { samples });
    cancelling = false;
    $("robust-progress").hidden = false;
    $("robust-cancel").hidden = false;
    $("robust-start").disabled = true;
    setMessage($("robust-message"), "walking the variations …");
  } catch (err) {
    setMessage($("robust-message"), formatDetail(err.raw) || err.message, "error");
  }
}

async function cancelRobustness() {
  if (!job) return;
  try {
    await api.del(`/api/jobs/${job.id}`); // it ends at its next run: followJob sees it
    cancelling = true;
    setMessage($("robust-message"), "cancelling …");
  } catch (err) {
    setMessage($("robust-message"), formatDetail(err.raw) || err.message, "error");
  }
}

async function followJob() {
  const now = await api.get(`/api/jobs/${job.id}`);
  $("robust-progress").value = now.progress;
  if (now.status === "running") {
    const d = now.detail;
    if (d?.runs_total && !cancelling) {
      setMessage($("robust-message"), `walking the variations: ${d.runs} of ${d.runs_total} runs walked · ${aboutLeft(d.left_s)}`);
    }
    return;
  }
  job = null;
  $("robust-progress").hidden = true;
  $("robust-start").disabled = false;
  hideKeepingFocus($("robust-cancel"), $("robust-start"));
  if (now.status === "cancelled") {
    setMessage($("robust-message"), "robustness cancelled: no report", "warn");
    return;
  }
  if (now.status === "failed") {
    setMessage($("robust-message"), `robustness failed: ${now.error}`, "error");
    return;
  }
  setMessage($("robust-message"), "", "");
  drawReport(now.result);
}

async function showLastReport() {
  if (job) return; // the running job's report comes when it ends
  try {
    // the state says whether the gait in use has a report: none is asked for (a 404) if not
    if ((await api.get("/api/state")).robustness_report) {
      drawReport(await api.get("/api/world/robustness"));
      return;
    }
  } catch (err) {
    if (err.status !== 404) return; // the server is away; a 404: it went with a change meanwhile
  }
  if (reportTitle) $("robust-title").textContent = `(of an earlier gait) ${reportTitle}`;
}

/** A worst variation's terms, those in the outer tenth of their default range on their side of
 *  the nominal value (or past it) marked: what most likely made it fail. A low gyro noise is
 *  near the nominal model, not an extreme. */
function variationTerms(text) {
  return terms(text).map(([key, value], i) => {
    const range = ranges[key.startsWith("cal.") ? "calibration_deg" : key];
    const v = Number(value);
    let extreme = false;
    if (range && !CIRCULAR.has(key) && range[1] > range[0]) {
      const [lo, hi] = range, edge = EXTREME * (hi - lo);
      const nominal = key.startsWith("cal.") ? 0 : nominalOf(key);
      extreme = (v > nominal && v >= hi - edge) || (v < nominal && v <= lo + edge);
    }
    const [label, unit] = FEATURES[key] ?? (key.startsWith("cal.") ? [`${key.slice(4)} calibration`, "°"] : [key, ""]);
    const units = unit && unit !== "×" ? ` ${unit}` : "";
    const span = range ? `its default range ${range[0]} to ${range[1]}${units}` : "";
    const title = !range ? label : extreme
      ? `${label}: ${value}${units}, in the outer tenth of ${span}, on the far side from the nominal model: the likeliest cause of this variation's failures`
      : `${label}: ${value}${units} (${span})`;
    return h("span", { class: extreme ? "term extreme" : "term", title },
      `${key}=${value}${i < text.split(",").length - 1 ? "," : ""} `);
  });
}

export function drawReport(result) {
  const report = result.presets[0];
  const when = result.finished_at
    ? ` — kept from ${new Date(1000 * result.finished_at).toLocaleTimeString()}, v${result.params_version}`
    : "";
  reportTitle = `${report.preset} on ${result.samples} variations (seed ${result.seed}): ${(100 * report.overall_share).toFixed(0)} % of runs pass${when}`;
  $("robust-title").textContent = reportTitle;
  $("robust-bars").replaceChildren(
    h("div", { class: "robust-row robust-header dim" },
      h("span", {}, "case"), h("span", {}, "runs passing, 95 % interval (dotted: 90 %)"),
      h("span", { class: "robust-share" }, "pass"), h("span", {}, "failures depend on")),
    ...report.cases.map((c) => {
      const [lo, hi] = c.interval;
      const pct = (x) => `${(100 * x).toFixed(1)}%`;
      const level = c.share >= 0.9 ? "ok" : c.share >= 0.6 ? "warn" : "bad";
      const [depends, why] = dependsOn(c.depends_on);
      return h("div", { class: "robust-row", title: why },
        h("span", { class: "robust-case" }, c.case),
        h("span", { class: "robust-track" },
          h("span", { class: `robust-bar ${level}`, style: `width:${pct(c.share)}` }),
          h("span", { class: "robust-ci", style: `left:${pct(lo)};width:${pct(hi - lo)}` })),
        h("span", { class: "robust-share" }, `${(100 * c.share).toFixed(0)} %`),
        depends);
    }),
  );
  $("robust-worst").replaceChildren(
    ...report.worst.map((w) =>
      h("li", {},
        h("button", { type: "button", class: "small", onclick: () => watch(w) }, "Walk in it"),
        ` fails ${w.failed_cases}: ${w.failed.join(", ")} `,
        h("code", { class: "small dim robust-variation" }, ...variationTerms(w.variation)))),
  );
  // the highlighted values, explained once under the list (issue 56, item 15)
  $("robust-legend").hidden = !$("robust-worst").querySelector(".term.extreme");
}

async function watch(worst) {
  await apply(worst.variation);
  if (worst.motion) await api.patch("/api/params", { motion: worst.motion }); // its first failed case's
  await api.post("/api/sim/reset");
  setMessage($("world-message"), `walking ${worst.failed[0]} in the variation that failed it`, "ok");
}
