// The path panel: the top view (path-plot.js, uPlot) of the trunk's actual path against the
// differential-drive prediction (seed 004), its readouts, Clear, re-anchoring and the axle b
// (by hand, the feet, or fitted; a fitted b of another gait is marked stale).

import { api, poll } from "./api.js";
import { cycleMeans, PathPlot } from "./path-plot.js";
import { $, fieldNumber, fmt, setMessage } from "./util.js";

let plot = null;
let last = null;
let freqHz = null; // the gait clock, for the per-cycle means
let fallen = false; // after a fall the measured speeds are the fall's: the readouts go blank

window.artro = window.artro || {};

export function initPaths() {
  plot = new PathPlot($("path-plot"));
  $("path-anchor").addEventListener("click", reanchor);
  $("path-clear").addEventListener("click", clearPath);
  $("axle-set").addEventListener("click", setAxle);
  $("axle-fit").addEventListener("click", fitAxle);
  $("ca-calibrate").addEventListener("click", calibrateCa);
  $("job-cancel").addEventListener("click", cancelJob);
  $("job-apply").addEventListener("click", applyKept);
  $("path-cycles").addEventListener("change", () => last && show(last));
  document.addEventListener("artro:state", (e) => {
    fallen = !!e.detail.fell;
    if (last) readout(last);
  });
  document.addEventListener("artro:params", (e) => {
    freqHz = e.detail.gait?.clock?.freq_hz ?? null;
  });
  poll(async () => {
    try {
      show(await api.get("/api/path"));
    } catch (err) {
      $("path-readout-v").textContent = "—";
      throw err;
    }
  }, 500);
}

function show(p) {
  last = p;
  const means = $("path-cycles").checked ? cycleMeans(p.actual, freqHz) : null;
  plot.update(p, means);
  window.artro.path = {
    actual: p.actual.length,
    predicted: p.predicted.length,
    cycles: means?.[0].length ?? 0,
    lastT: p.actual.length ? p.actual[p.actual.length - 1][0] : null,
    view: plot.view(),
  };
  readout(p);
}

async function clearPath() {
  try {
    await api.post("/api/path/clear");
    setMessage($("path-message"), "path cleared; the prediction starts again here", "ok");
    show(await api.get("/api/path"));
  } catch (err) {
    setMessage($("path-message"), err.message, "error");
  }
}

/** A "by hand" field in its own unit: null when empty; an Error saying what it takes (in that
 *  unit, with the page's name for it) for junk or a value out of its range. */
function byHand(id, what, unit, empty) {
  const input = $(id);
  const raw = input.value.trim();
  const takes = `${what} by hand takes ${input.min} to ${input.max} ${unit}, or nothing for ${empty}`;
  if (input.validity.badInput) throw new Error(`${what}: not a number, nothing changed — ${takes}`);
  if (raw === "") return null;
  const v = fieldNumber(input);
  if (v === null) throw new Error(`${what} = ${raw} ${unit} not applied — ${takes}`);
  return v;
}

/** The server's refusal of a by-hand value, told in the field's unit and name. */
function refusal(err, what, raw, unit, id) {
  const input = $(id);
  if (err.status !== 422) return err.message;
  return `${what} = ${raw} ${unit} not applied — ${what} by hand takes ${input.min} to ${input.max} ${unit}`;
}

async function reanchor() {
  const msg = $("path-message");
  let cm;
  try {
    cm = byHand("anchor-speed", "V", "cm/s", "the measured speed");
  } catch (err) {
    setMessage(msg, err.message, "error");
    return;
  }
  try {
    await api.post("/api/path/anchor", cm === null ? {} : { speed_m_s: cm / 100 });
    setMessage(msg, cm === null ? "re-anchored; V measured" : `re-anchored with V = ${cm} cm/s`, "ok");
  } catch (err) {
    setMessage(msg, refusal(err, "V", cm, "cm/s", "anchor-speed"), "error");
  }
}

async function setAxle() {
  const msg = $("path-message");
  let cm;
  try {
    cm = byHand("axle-cm", "b", "cm", "the distance between the feet");
  } catch (err) {
    setMessage(msg, err.message, "error"); // junk never drops the b in use
    return;
  }
  try {
    await api.put("/api/path/axle", { axle_m: cm === null ? null : cm / 100 });
    setMessage(msg, cm === null ? "b = the distance between the feet" : `b = ${cm} cm`, "ok");
  } catch (err) {
    setMessage(msg, refusal(err, "b", cm, "cm", "axle-cm"), "error");
  }
}

let running = null; // the job being followed: Cancel stops it
let kept = null; // a finished job whose result could not be applied: Apply applies it

/** Follow a background job (202 at once) to its end, showing its progress in `msg`; Cancel
 *  stops it meanwhile. The job's result, or null once cancelled. */
async function followJob(job, msg, label) {
  running = job;
  showJobActions();
  try {
    while (job.status === "running") {
      setMessage(msg, `${label} … ${fmt(job.progress * 100, 0)} %`, "");
      await new Promise((resolve) => setTimeout(resolve, 500));
      job = await api.get(`/api/jobs/${job.id}`);
    }
  } finally {
    running = null;
    showJobActions();
  }
  if (job.status === "cancelled") {
    setMessage(msg, `${label}: cancelled, nothing applied`, "quiet");
    return null;
  }
  if (job.status !== "done") throw new Error(`${label}: ${job.error}`);
  if (job.result?.conflict) {
    kept = job; // the parameters (or b) changed while it ran: the user may still apply it
    showJobActions();
  }
  return job.result;
}

function showJobActions() {
  $("job-cancel").hidden = !running;
  $("job-apply").hidden = !kept || !!running;
  $("job-actions").hidden = $("job-cancel").hidden && $("job-apply").hidden;
}

async function cancelJob() {
  if (!running) return;
  try {
    await api.del(`/api/jobs/${running.id}`);
  } catch (err) {
    setMessage($("path-message"), err.message, "error");
  }
}

/** Apply a kept result onto the parameters in use now. */
async function applyKept() {
  const msg = $("path-message");
  const job = kept;
  if (!job) return;
  try {
    const { version } = await api.get("/api/params");
    const done = await api.post(`/api/jobs/${job.id}/apply`, { version });
    kept = null;
    const r = done.result;
    const text = job.kind === "calibrate-ca"
      ? `the fitted K applied as version ${r.params_version} (undoable)`
      : `b_eff = ${fmt(r.axle_eff_m * 100, 1)} cm applied`;
    setMessage(msg, text, "ok");
  } catch (err) {
    setMessage(msg, err.message, "error");
  }
  showJobActions();
}

/** Why a finished job's result was not applied, for the page: "not applied: the axle b was set
 *  while the fit ran; 'Apply it anyway' applies it now". */
const notApplied = (r) =>
  `not applied: ${r.conflict.msg.split(": not applied")[0]}; "Apply it anyway" applies it now`;

async function calibrateCa() {
  const msg = $("path-message");
  const button = $("ca-calibrate");
  button.disabled = true;
  kept = null;
  try {
    const label = "calibrating CA: curve walks forward and backward";
    const r = await followJob(await api.post("/api/jobs/calibrate-ca", {}), msg, label);
    if (!r) return;
    const part = (name, d) =>
      !d ? "" : d.error ? `${name}: ${d.error}` :
        `${name} K = ${fmt(d.yaw_per_ca, 3)} (${fmt(d.gain * 100, 0)} % of eq (13))`;
    const text = [part("forward", r.forward), part("backward", r.backward)].filter(Boolean).join("; ");
    if (r.conflict) setMessage(msg, `${text} — ${notApplied(r)}`, "error");
    else setMessage(msg, `${text} — applied as version ${r.params_version} (undoable)`, "ok");
  } catch (err) {
    setMessage(msg, err.message, "error");
  } finally {
    button.disabled = false;
  }
}

async function fitAxle() {
  const msg = $("path-message");
  const button = $("axle-fit");
  button.disabled = true;
  kept = null;
  try {
    // a background job (202 at once); its progress is polled, never a minute-long request
    const label = "fitting b: simulating CA = -0.1, 0, +0.1 for 20 s each";
    const r = await followJob(await api.post("/api/jobs/axle-fit", {}), msg, label);
    if (!r) return;
    const gain = r.gain == null ? "no steering" : `${fmt(r.gain * 100, 0)} % of eq (13)`;
    const fit = `b_eff = ${fmt(r.axle_eff_m * 100, 1)} cm (feet ${fmt(r.feet_m * 100, 1)} cm): CA steers at ${gain}`;
    if (r.applied) setMessage(msg, fit, "ok");
    else if (r.conflict) setMessage(msg, `${fit} — ${notApplied(r)}`, "error");
    else setMessage(msg, `not applied: ${r.reason}`, "error");
  } catch (err) {
    setMessage(msg, err.message, "error");
  } finally {
    button.disabled = false;
  }
}

function readout(p) {
  if (fallen) {
    for (const dd of $("path-readout").querySelectorAll("dd")) dd.textContent = "—";
    return;
  }
  const cms = (v) => (v == null ? "—" : `${fmt(v * 100, 2)} cm/s`);
  $("path-readout-v").textContent = cms(p.speed_m_s);
  $("path-readout-vsrc").textContent = p.speed_source ? `(${p.speed_source})` : "";
  $("path-readout-b").textContent = p.axle_m == null ? "—" : `${fmt(p.axle_m * 100, 1)} cm`;
  $("path-readout-bsrc").textContent = p.axle_source ? `(${p.axle_source}${p.axle_stale ? ", stale" : ""})` : "";
  $("path-readout-bsrc").parentElement.classList.toggle("stale", !!p.axle_stale);
  $("path-readout-bsrc").parentElement.title = p.axle_stale
    ? "fitted for another gait: Fit b again, or set b"
    : "axle of the differential-drive model: the measured distance between the feet, a fitted effective axle, or one set by hand";
  $("path-readout-ca").textContent = fmt(p.ca, 3);
  $("path-readout-r").textContent = p.turn_radius_m == null ? "straight" : `${fmt(p.turn_radius_m, 2)} m`;
  $("path-readout-rate-pred").textContent = `${fmt(p.predicted_turn_deg_s, 2)} °/s`;
  $("path-readout-rate-act").textContent = `${fmt(p.actual_turn_deg_s, 2)} °/s`;
  $("path-readout-fwd").textContent = cms(p.actual_forward_m_s);
  $("path-readout-lat").textContent = cms(p.actual_lateral_m_s);
}

