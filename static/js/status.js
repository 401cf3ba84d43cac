// Header: simulation status from GET /api/state (polled at 2 Hz, announced as "artro:state") and
// the sim controls. The state reads "running 1.00×", "paused" or "fallen — stopped": a real-time
// factor only while the simulation runs, and once its 2 s window has filled (the target is the
// speed select beside it).

import { api, poll } from "./api.js";
import { $, fmt } from "./util.js";

let lastVersion = null;
let speedBusyUntil = 0; // don't overwrite the speed select right after the user changed it
const RTF_WINDOW_S = 2; // the server's real-time-factor window (app/server/sim/pacing.py)
const NOTE_MS = 8000; // a status note goes away after this long
let noteTimer = null;

export function initStatus() {
  for (const id of ["sim-resume", "sim-step"]) $(id).dataset.title = $(id).title;
  for (const action of ["pause", "resume", "step", "reset"]) {
    $(`sim-${action}`).addEventListener("click", () => control(action));
  }
  $("speed-select").addEventListener("change", async (e) => {
    speedBusyUntil = performance.now() + 1500;
    try {
      await api.put("/api/sim/speed", { speed: Number(e.target.value) });
      note("");
    } catch (err) {
      note(err.message);
    }
  });
  poll(refresh, 500);
}

async function control(action) {
  try {
    await api.post(`/api/sim/${action}`);
    note("");
    setTimeout(refresh, 120);
  } catch (err) {
    note(err.message);
  }
}

/** A note under the header for NOTE_MS: an error's colours unless `kind` is "info" (what was done,
 *  such as the firmware now driving the servos: issue 56, item 17). */
export function note(text, kind = "error") {
  $("status-note").textContent = text;
  $("status-note").hidden = !text;
  $("status-note").className = `status-note ${kind}`;
  clearTimeout(noteTimer);
  if (text) noteTimer = setTimeout(() => note(""), NOTE_MS);
}

async function refresh() {
  let s;
  try {
    s = await api.get("/api/state");
  } catch (err) {
    show("link-badge", true, "server offline");
    // what we knew about the simulation is stale now
    for (const id of ["behind-badge", "paused-badge", "errors-badge"]) show(id, false);
    $("sim-rtf").textContent = "—";
    throw err;
  }
  show("link-badge", false);
  $("sim-time").textContent = `${fmt(s.sim_time_s, 2)} s`;
  $("sim-rtf").textContent = stateText(s);
  $("sim-rtf").classList.toggle("bad", !!s.fell);
  $("sim-rtf").title = `real-time factor achieved while the simulation runs (target: ${Number(s.speed)}×, the speed setting)`;
  show("behind-badge", !!s.behind && !s.fell && !s.paused);
  show("paused-badge", !!s.paused);
  $("sim-pause").hidden = !!s.paused;
  $("sim-resume").hidden = !s.paused;
  const replaying = !!s.replay?.active; // the live simulation may not run under a replay
  for (const id of ["sim-resume", "sim-step"]) {
    $(id).disabled = replaying;
    $(id).title = replaying ? "a replay is shown: 'Back to live' resumes the simulation" : $(id).dataset.title ?? $(id).title;
  }
  const errors = s.errors || [];
  show("errors-badge", errors.length > 0, `${errors.length} error${errors.length > 1 ? "s" : ""}`);
  $("errors-badge").title = errors.map((e) => (typeof e === "string" ? e : JSON.stringify(e))).join("\n");
  if (performance.now() > speedBusyUntil && document.activeElement !== $("speed-select")) {
    const sel = $("speed-select");
    const v = String(Number(s.speed));
    if ([...sel.options].some((o) => o.value === v)) sel.value = v;
  }
  $("sim-version").textContent = `v${s.params_version}`;
  document.dispatchEvent(new CustomEvent("artro:state", { detail: s }));
  if (s.params_version !== lastVersion) {
    lastVersion = s.params_version;
    document.dispatchEvent(new CustomEvent("artro:params-version", { detail: s.params_version }));
  }
}

function stateText(s) {
  if (s.replay?.active) return "replaying — paused";
  if (s.fell) return "fallen — stopped";
  if (s.paused) return "paused";
  const rtf = s.rtf == null || s.sim_time_s < RTF_WINDOW_S ? "—" : `${fmt(s.rtf, 2)}×`;
  return `running ${rtf}`;
}

function show(id, visible, text) {
  const el = $(id);
  el.hidden = !visible;
  if (text != null) el.textContent = text;
}
