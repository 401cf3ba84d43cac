// "Current parameters": the motion vector and CA with what their signs mean, the gait clock,
// which walking phases are on, the parameter version; Undo / Redo.

import { api } from "./api.js";
import { $, fmt, fmtSigned, h, setMessage } from "./util.js";

// What a positive / negative value does (docs/DESIGN.md §3, as the equations stand).
const MOTION = [
  { key: "a_p", label: "a_p", what: "sagittal", pos: "walks forward", neg: "walks backward" },
  { key: "a_r", label: "a_r", what: "lateral", pos: "steps right", neg: "steps left" },
  { key: "a_y", label: "a_y", what: "rotation", pos: "turns clockwise", neg: "turns counter-clockwise" },
  { key: "ca", label: "CA", what: "curve amount", pos: "curves clockwise (left steps longer)", neg: "curves counter-clockwise (right steps longer)" },
];
const PHASES = ["shift", "short", "swing", "load", "balance"];

export function initParams() {
  $("params-undo").addEventListener("click", () => step("undo"));
  $("params-redo").addEventListener("click", () => step("redo"));
  // the header's state poll tells us when the parameter version moved
  document.addEventListener("artro:params-version", () => refreshParams());
}

async function step(action) {
  const msg = $("params-message");
  try {
    const p = await api.post(`/api/params/${action}`);
    render(p);
    setMessage(msg, `${action === "undo" ? "undone" : "redone"} → v${p.version}`, "ok");
  } catch (err) {
    // 409: nothing to undo/redo - not an error worth shouting about
    setMessage(msg, err.status === 409 ? err.message : err.message, err.status === 409 ? "quiet" : "error");
  }
}

export async function refreshParams() {
  try {
    render(await api.get("/api/params"));
  } catch (err) {
    setMessage($("params-message"), err.message, "error");
  }
}

function render(p) {
  $("params-version").textContent = `v${p.version}`;
  $("params-name").textContent = p.name || "—";
  const body = $("params-motion");
  body.replaceChildren(
    ...MOTION.map((m) => {
      const v = p.motion?.[m.key] ?? 0;
      // the sign's meaning; at zero, say what a positive value would do
      const hint = v > 0 ? m.pos : v < 0 ? m.neg : `> 0 ${m.pos}`;
      return h(
        "tr",
        { id: `param-${m.key}` },
        h("th", {}, m.label, h("span", { class: "dim" }, ` ${m.what}`)),
        h("td", { class: "num" }, fmtSigned(v, 3)),
        h("td", { class: v === 0 ? "hint dim" : "hint" }, hint),
      );
    }),
  );
  const g = p.gait || {};
  $("params-clock").textContent = `${fmt(g.clock?.freq_hz, 2)} Hz`;
  $("params-phases").replaceChildren(
    ...PHASES.map((ph) => h("span", { class: `chip ${g[ph]?.enabled === false ? "off" : "on"}` }, ph)),
  );
}
