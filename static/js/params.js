// The parameter set in use: its name, version, gait clock and which walking phases are on; Undo /
// Redo. The one place that reads GET /api/params: it announces every set it gets as the
// "artro:params" event (the motion controls, the fall notice and the path view listen).

import { api } from "./api.js";
import { $, fmt, h, setMessage } from "./util.js";

const PHASES = ["shift", "short", "swing", "load", "balance"];

export function initParams() {
  $("params-undo").addEventListener("click", () => step("undo"));
  $("params-redo").addEventListener("click", () => step("redo"));
  // the header's state poll tells us when the parameter version moved
  document.addEventListener("artro:params-version", () => refreshParams());
  document.addEventListener("artro:params", (e) => render(e.detail));
}

async function step(action) {
  const msg = $("params-message");
  try {
    const before = robotShown;
    const p = await api.post(`/api/params/${action}`);
    announce(p);
    const robot = p.robot !== before ? `: the robot is ${p.robot} again (was ${before})` : "";
    setMessage(msg, `${action === "undo" ? "undone" : "redone"} → v${p.version}${robot}`, "ok");
  } catch (err) {
    // 409: nothing to undo/redo - not an error worth shouting about
    setMessage(msg, err.message, err.status === 409 ? "quiet" : "error");
  }
}

export async function refreshParams() {
  try {
    announce(await api.get("/api/params"));
  } catch (err) {
    setMessage($("params-message"), err.message, "error");
  }
}

let shown = 0;
let robotShown = null; // the robot of the set shown

/** Tell every listener about a parameter set, unless an older one than already shown. */
export function announce(p) {
  if (p.version < shown) return;
  document.dispatchEvent(new CustomEvent("artro:params", { detail: p }));
}

function render(p) {
  if (p.version < shown) return;
  shown = p.version;
  robotShown = p.robot;
  $("params-version").textContent = `v${p.version}`;
  $("params-name").textContent = p.name || "—";
  const g = p.gait || {};
  $("params-clock").textContent = `${fmt(g.clock?.freq_hz, 2)} Hz`;
  $("params-phases").replaceChildren(
    ...PHASES.map((ph) => h("span", { class: `chip ${g[ph]?.enabled === false ? "off" : "on"}` }, ph)),
  );
}
