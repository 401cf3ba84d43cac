// The servo load budget panel: GET /api/servos/load twice a second, one row per servo,
// each margin coloured by the level the server gives it (app/sim/servo_load.py), and for the
// rows under 10 % what that means. The colours are a caution's (green, amber, orange), never a
// failure's red: the budget says what a real robot's servos would need for this gait, which is
// no fault of the simulation (issue 56, item 17). A servo short of eq (1) is named with the one
// that would meet it.

import { api, poll } from "./api.js";
import { $, fmt, h } from "./util.js";

const pct = (x) => `${Math.round(100 * x)} %`;

function row(j) {
  return h(
    "tr",
    { class: `level-${j.level}`, "data-servo": j.joint },
    h("td", { title: j.servo }, j.joint),
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

const names = (rows) => rows.map((j) => j.joint).join(", ");

/** Rows by a key, in their order: [[key, rows], ...]. */
function grouped(rows, key) {
  const groups = new Map();
  for (const j of rows) groups.set(key(j), [...(groups.get(key(j)) ?? []), j]);
  return [...groups.values()];
}

/** "the DS3218 (2.00 N·m at 6 V, 60 g)" would meet eq (1) for these rows, or that none does. */
function meetsIt(rows, voltage, atLeast) {
  const need = `${atLeast ? "at least " : ""}${fmt(Math.max(...rows.map((j) => j.required_torque_nm)))}`;
  const choice = rows.map((j) => j.eq1_servo).filter(Boolean)
    .sort((a, b) => b.stall_torque_nm - a.stall_torque_nm)[0];
  if (!choice) {
    return `No servo of models/servos.yaml (nor of the robot's own) gives ${need} N·m: a gait that asks less of them would meet it.`;
  }
  const at = voltage ? ` at ${voltage} V` : "";
  return (
    `A servo of ${need} N·m would meet it: the ${choice.name} (${fmt(choice.stall_torque_nm)} N·m${at}, ` +
    `${Math.round(1000 * choice.mass_kg)} g) is the lightest of models/servos.yaml (and the robot's ` +
    `own servos) that does.`
  );
}

/** What the rows under 10 % mean, in words: null when there are none. */
export function budgetNote(report) {
  const low = report.joints.filter((j) => j.level === "critical");
  if (!low.length) return null;
  const sf = Math.round(100 * report.safety_factor);
  const strong = low.filter((j) => j.torque_level === "critical");
  const parts = [];
  for (const rows of grouped(strong.filter((j) => !j.eq1_met), (j) => j.servo)) {
    const servo = rows[0].servo;
    const stall = fmt(rows[0].stall_torque_nm);
    const stalled = rows.filter((j) => j.peak_torque_nm >= AT_STALL * j.stall_torque_nm);
    const peak = Math.max(...rows.map((j) => j.peak_torque_nm));
    if (stalled.length) {
      parts.push(
        `${names(rows)}: the margin is below eq (1)'s safety factor. ${names(stalled)} reached ` +
          `the ${servo}'s stall torque (${stall} N·m) at some moment: the servo was at its limit ` +
          `there (the simulated one gives no more, like the real one), so eq (1), which asks ` +
          `${sf} % more than the peak, reads −${sf} %, the lowest it can.`,
      );
    } else {
      const over = Math.max(0, Math.round(100 * (rows[0].stall_torque_nm / peak - 1)));
      parts.push(
        `${names(rows)}: the margin is below eq (1)'s safety factor. Their peak torque, up to ` +
          `${fmt(peak)} N·m, is within the ${servo}'s stall torque of ${stall} N·m, but by ` +
          `${over} %, where eq (1) asks ${sf} % more than the peak: ` +
          `${fmt(Math.max(...rows.map((j) => j.required_torque_nm)))} N·m.`,
      );
    }
    parts.push(meetsIt(rows, report.supply_voltage_v, stalled.length > 0)); // a stall hides the need
  }
  const near = strong.filter((j) => j.eq1_met);
  if (near.length) {
    parts.push(
      `${names(near)} meet eq (1) (${sf} % over the peak torque) with less than 10 % of the ` +
        `stall torque left.`,
    );
  }
  const fast = low.filter((j) => j.speed_level === "critical");
  if (fast.length) parts.push(`${names(fast)} turn within 10 % of the servo's no-load speed.`);
  return (
    `Caution — ${parts.join(" ")} It is what this gait asks of them, walking or ` +
    `not (motion 0 still steps on the spot), so it is expected while this gait runs and is no ` +
    `fault of the simulation: it says what a real robot walking it would need.`
  );
}

export function initServoLoad() {
  const body = $("servo-body");
  poll(async () => {
    const report = await api.get("/api/servos/load");
    $("servo-frames").textContent = `${report.frames} frames (${(report.frames * 0.02).toFixed(1)} s)`;
    body.replaceChildren(...report.joints.map(row));
    const note = budgetNote(report);
    $("servo-note").hidden = !note;
    $("servo-note").textContent = note ?? "";
  }, 500);
}
