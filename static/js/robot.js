// The robot simulated, and a switch to another (GET /api/robots, PUT /api/robot): the robot starts
// over, standing, in its own preset; the switch is a parameter version, so Undo takes it back.
// Refused, said why, while a job or a replay runs or the firmware drives.

import { api, formatDetail } from "./api.js";
import { $, fmt, h, setMessage } from "./util.js";

let offered = [];
let shown = null; // the robot the state last named

export async function initRobot() {
  $("robot-select").addEventListener("change", (e) => switchTo(e.target.value));
  const list = await api.get("/api/robots");
  offered = list.robots;
  $("robot-select").replaceChildren(
    ...offered.map((r) => h("option", { value: r.name, title: r.title }, r.name)),
  );
  shown = null; // the state poll may have named it before the figures were here
  showRobot(list.loaded);
}

const figures = (r) =>
  r ? `${fmt(r.total_mass_kg, 2)} kg, legs ${fmt(100 * r.leg_m, 1)} cm, preset '${r.default_preset}'` : "";

/** The robot the state names (the header badge, the select unless being changed). */
export function showRobot(name) {
  if (!name || name === shown) return;
  shown = name;
  const robot = offered.find((r) => r.name === name);
  $("robot-badge").textContent = `robot ${name}`;
  $("robot-badge").title = robot ? `${robot.title}: ${figures(robot)}` : "the robot simulated";
  if (document.activeElement !== $("robot-select")) $("robot-select").value = name;
  $("robot-figures").textContent = figures(robot);
}

async function switchTo(name) {
  const from = shown;
  const msg = $("robot-message");
  try {
    const done = await api.put("/api/robot", { name });
    const p = done.params;
    showRobot(name);
    setMessage(
      msg,
      done.changed
        ? `now ${name}: it started over in its preset '${p.name}' (v${p.version}); Undo goes back to ${from}`
        : `${name} is already simulated`,
      "ok",
    );
    document.dispatchEvent(new CustomEvent("artro:params", { detail: p }));
  } catch (err) {
    $("robot-select").value = from;
    setMessage(msg, `still ${from}: ${formatDetail(err.raw) || err.message}`, "error");
  }
}
