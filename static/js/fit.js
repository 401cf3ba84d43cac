// "Fit to a recording" (POST /api/fit, docs/FIT.md "On the dashboard"): a REC.json of the identify
// routine picked or dropped is checked by the server and fitted by `artro fit` in the background on
// the robot shown; a progress bar with the best loss and the time left, Cancel (DELETE
// /api/jobs/{id}); done, the fitted fields (value ± σ, told or why not, a simulated recording's
// truth), the report's plot, and "Use the fitted robot", which sets the fit as the World.

import { api, formatDetail } from "./api.js";
import { fileDrop, jobFollower } from "./job-follow.js";
import { $, fieldNumber, fieldRule, fmt, h, hideKeepingFocus, setMessage } from "./util.js";

const MAX_BYTES = 16 * 1024 * 1024; // the server's cap on a recording (app/server/http/request_gate.py)
const fit = jobFollower({ messageId: "fit-message", show, finish }); // the fit followed
let fitted = null; // the last fit done: {variation, world}

export function initFit() {
  fileDrop($("fit-box"), $("fit-file"), start, { messageId: "fit-message", what: "recording (REC.json)" });
  $("fit-cancel").addEventListener("click", fit.cancel);
  $("fit-use").addEventListener("click", useFit);
  fit.watch("fit", (now) => {
    running(now);
    setMessage($("fit-message"), "fitting a recording sent before this page was loaded…");
  });
}

async function start(file) {
  if (fit.job) return;
  const msg = $("fit-message");
  if (file.size > MAX_BYTES) {
    setMessage(msg, `not fitted: ${file.name} has ${file.size} bytes; a recording may have ${MAX_BYTES}`, "error");
    return;
  }
  const query = new URLSearchParams();
  const fields = $("fit-fields").value.trim();
  if (fields) query.set("fields", fields);
  const budget = fieldNumber($("fit-budget"));
  if (budget === null) {
    setMessage(msg, `not fitted: replays ${fieldRule($("fit-budget"))}`, "error");
    return;
  }
  query.set("budget", budget);
  try {
    running(await api.postRaw(`/api/fit?${query}`, await file.text(), "application/json"));
    setMessage(msg, `fitting ${file.name} on the robot shown…`);
  } catch (err) {
    setMessage(msg, `not fitted: ${formatDetail(err.raw) || err.message}`, "error");
  }
}

function running(now) {
  fit.job = now;
  $("fit-file").disabled = true;
  $("fit-cancel").hidden = false;
  $("fit-progress-row").hidden = false;
  $("fit-result").hidden = true;
  show(now);
}

function show(now) {
  const d = now.detail || {};
  $("fit-progress").value = now.progress;
  const best = d.best_loss == null ? "" : ` · best loss ${fmt(d.best_loss, 4)}`;
  const left = d.left ? ` · ${d.left} left`.replaceAll(" ", "\u00a0") : "";
  // the IMU's fields alone are found in closed form: no search, no percent until done
  $("fit-status").textContent = d.percent
    ? `${d.percent} % of the search${best}${left}`
    : "replaying the routine on the robot shown…";
}

function finish(now) {
  if (!fit.job || now.status === "running") return;
  fit.job = null;
  $("fit-file").disabled = false;
  hideKeepingFocus($("fit-cancel"), $("fit-file"));
  $("fit-progress-row").hidden = true;
  const msg = $("fit-message");
  if (now.status === "cancelled") setMessage(msg, "fit cancelled: its child stopped, nothing written", "warn");
  else if (now.status === "failed") setMessage(msg, `fit failed: ${now.error}`, "error");
  else showResult(now.result);
}

/** The fitted fields, the report's plot and the button that walks the fit. */
function showResult(r) {
  fitted = r;
  const truth = Object.values(r.fields).some((f) => f.truth != null);
  $("fit-truth-head").hidden = !truth;
  $("fit-table").tBodies[0].replaceChildren(
    ...Object.entries(r.fields).map(([name, f]) =>
      h("tr", {},
        h("td", {}, name),
        h("td", { class: "num" }, `${fmt(f.value, 3)} ± ${Number(f.sigma).toPrecision(2)}`),
        h("td", {}, f.identified ? "identified" : whyNot(name, r)),
        ...(truth ? [h("td", { class: "num" }, f.truth == null ? "—" : fmt(f.truth, 3))] : []),
      ),
    ),
  );
  $("fit-traces").src = `${r.traces}?t=${Date.now()}`;
  $("fit-result").hidden = false;
  const state = r.converged ? "converged" : `did not converge (${r.why_not}): the nominal kept`;
  setMessage($("fit-message"), `fit ${state}; fitted robot ${r.fitted}`, r.converged ? "ok" : "warn");
}

/** Why the recording did not tell a field: correlated with another, or flat (docs/FIT.md §3). */
function whyNot(name, r) {
  const pair = r.correlated.find((p) => p.includes(name));
  if (pair) return `not told: moves the traces as ${pair.find((n) => n !== name)} does`;
  if (r.flat.includes(name)) return "not told: the loss is flat in it";
  return "not told: its σ is too wide";
}

async function useFit() {
  if (!fitted) return;
  try {
    const done = await api.put("/api/world", { variation: fitted.variation });
    setMessage($("fit-message"), `walking the fitted robot: ${done.variation}`, "ok");
  } catch (err) {
    setMessage($("fit-message"), `not changed: ${formatDetail(err.raw) || err.message}`, "error");
  }
}
