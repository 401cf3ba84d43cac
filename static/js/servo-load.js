// The servo load budget panel: GET /api/servos/load twice a second, one row per servo,
// each margin coloured by the level the server gives it (app/core/servo_load.py).

import { api, poll } from "./api.js";
import { $, fmt, h } from "./util.js";

const pct = (x) => `${Math.round(100 * x)} %`;

function row(j) {
  return h(
    "tr",
    { class: `level-${j.level}`, "data-servo": j.joint },
    h("td", {}, j.joint),
    h("td", { class: "num" }, fmt(j.peak_torque_nm)),
    h("td", { class: "num" }, fmt(j.rms_torque_nm)),
    h("td", { class: "num" }, fmt(j.required_torque_nm)),
    h("td", { class: "num" }, fmt(j.stall_torque_nm)),
    h("td", { class: `num margin ${j.torque_level}` }, pct(j.torque_margin)),
    h("td", { class: "num" }, fmt(j.peak_speed_rad_s)),
    h("td", { class: `num margin ${j.speed_level}` }, pct(j.speed_margin)),
    h("td", { class: "num" }, String(j.saturated_frames)),
  );
}

export function initServoLoad() {
  const body = $("servo-body");
  poll(async () => {
    const report = await api.get("/api/servos/load");
    $("servo-frames").textContent = `${report.frames} frames (${(report.frames * 0.02).toFixed(1)} s)`;
    body.replaceChildren(...report.joints.map(row));
  }, 500);
}
