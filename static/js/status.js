// Header: simulation status from GET /api/state (polled at 2 Hz) and the sim controls.

import { api, poll } from "./api.js";
import { $, fmt } from "./util.js";

let lastVersion = null;
let speedBusyUntil = 0; // don't overwrite the speed select right after the user changed it

export function initStatus() {
  for (const action of ["pause", "resume", "step", "reset"]) {
    $(`sim-${action}`).addEventListener("click", () => control(action));
  }
  $("fallen-reset").addEventListener("click", () => control("reset"));
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

function note(text) {
  $("status-note").textContent = text;
  $("status-note").hidden = !text;
}

async function refresh() {
  let s;
  try {
    s = await api.get("/api/state");
  } catch (err) {
    show("link-badge", true, "server offline");
    // what we knew about the simulation is stale now
    for (const id of ["behind-badge", "fallen-badge", "fallen-reset", "paused-badge", "errors-badge"]) show(id, false);
    $("sim-rtf").textContent = "—";
    throw err;
  }
  show("link-badge", false);
  $("sim-time").textContent = `${fmt(s.sim_time_s, 2)} s`;
  const rtf = s.rtf == null ? "—" : `${fmt(s.rtf, 2)}×`;
  $("sim-rtf").textContent = `${rtf} / ${fmt(s.speed, 2)}×`;
  $("sim-rtf").title = "real-time factor achieved / target speed";
  show("behind-badge", !!s.behind);
  show("fallen-badge", !!s.fell);
  show("fallen-reset", !!s.fell);
  show("paused-badge", !!s.paused);
  $("sim-pause").hidden = !!s.paused;
  $("sim-resume").hidden = !s.paused;
  const errors = s.errors || [];
  show("errors-badge", errors.length > 0, `${errors.length} error${errors.length > 1 ? "s" : ""}`);
  $("errors-badge").title = errors.map((e) => (typeof e === "string" ? e : JSON.stringify(e))).join("\n");
  if (performance.now() > speedBusyUntil && document.activeElement !== $("speed-select")) {
    const sel = $("speed-select");
    const v = String(Number(s.speed));
    if ([...sel.options].some((o) => o.value === v)) sel.value = v;
  }
  $("sim-version").textContent = `v${s.params_version}`;
  if (s.params_version !== lastVersion) {
    lastVersion = s.params_version;
    document.dispatchEvent(new CustomEvent("artro:params-version", { detail: s.params_version }));
  }
}

function show(id, visible, text) {
  const el = $(id);
  el.hidden = !visible;
  if (text != null) el.textContent = text;
}
