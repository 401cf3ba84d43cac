// The servo load budget panel: GET /api/servos/load twice a second, one row per servo,
// each margin coloured by the level the server gives it (app/sim/servo_load.py), and for red
// rows what red means: the gait asks that much of the servo, whether or not the robot goes
// anywhere (motion 0 still steps on the spot).

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

const AT_STALL = 0.99; // a peak this close to the stall torque: the servo was at its limit

/** What the red rows mean, in words: null when no row is red. */
export function redNote(report) {
  const red = report.joints.filter((j) => j.level === "critical");
  if (!red.length) return null;
  const names = (rows) => rows.map((j) => j.joint).join(", ");
  const sf = Math.round(100 * report.safety_factor);
  const strong = red.filter((j) => j.torque_level === "critical");
  const stalled = strong.filter((j) => j.peak_torque_nm >= AT_STALL * j.stall_torque_nm);
  const fast = red.filter((j) => j.speed_level === "critical");
  const stall = fmt(red[0].stall_torque_nm);
  const need = fmt(Math.max(...strong.map((j) => j.required_torque_nm), 0));
  const parts = [];
  if (stalled.length) {
    parts.push(
      `${names(stalled)} reached the stall torque (${stall} N·m) at some moment: the servo was at ` +
        `its limit there (the simulated one gives no more, like the real one), so eq (1), which ` +
        `asks ${sf} % more than the peak, reads −${sf} %, the lowest it can.`,
    );
  }
  const near = strong.filter((j) => !stalled.includes(j));
  if (near.length) {
    parts.push(
      `For ${names(near)} eq (1) asks ${sf} % more than the peak torque, up to ${need} N·m ` +
        `against a stall torque of ${stall} N·m: less than 10 % of it left.`,
    );
  }
  if (fast.length) parts.push(`${names(fast)} turn within 10 % of the servo's no-load speed.`);
  const sizing = strong.length
    ? `; a real robot walking it would need servos of ${need} N·m there (eq (1)), or a gait that asks less of them`
    : "";
  return (
    `Red — ${names(red)}. ${parts.join(" ")} It is what this gait asks of them, walking or not ` +
    `(motion 0 still steps on the spot), so it is expected while this gait runs and is no fault ` +
    `of the simulation${sizing}.`
  );
}

export function initServoLoad() {
  const body = $("servo-body");
  poll(async () => {
    const report = await api.get("/api/servos/load");
    $("servo-frames").textContent = `${report.frames} frames (${(report.frames * 0.02).toFixed(1)} s)`;
    body.replaceChildren(...report.joints.map(row));
    const note = redNote(report);
    $("servo-note").hidden = !note;
    $("servo-note").textContent = note ?? "";
  }, 500);
}
