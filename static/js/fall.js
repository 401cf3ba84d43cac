// After a fall: a notice that names the motion the robot fell with (and the push it fell after,
// if one came in the seconds before: issue 56, item 17) and offers "Reset" (the same motion
// again) and "Reset with motion 0". A motion changed after the fall (undo, a slider, a preset) is
// named too, and the reset button then says it walks the new one: the simulation is never left
// stopped without a word.

import { api } from "./api.js";
import { $, fmtSigned, setMessage } from "./util.js";

const ZERO = { a_r: 0, a_p: 0, a_y: 0, ca: 0 };
let params = null; // the last parameter set announced
let fell = null; // {t, motion, push} of the fall on screen, or null
// a push this many simulated seconds or less before a fall is named as what it fell after
export const PUSH_BEFORE_FALL_S = 5;

export function initFall() {
  document.addEventListener("artro:params", (e) => {
    params = e.detail;
    if (fell && !fell.motion) fell.motion = params.motion ?? null; // the page opened after the fall
    if (fell) show();
  });
  document.addEventListener("artro:state", (e) => onState(e.detail));
  $("fall-reset").addEventListener("click", () => reset(false));
  $("fall-reset-zero").addEventListener("click", () => reset(true));
}

/** "0.6 s after a push of 0.80 N·s toward 90° (its left)": the push `s.push` of a state that
 *  fell, if it came at most PUSH_BEFORE_FALL_S before `t`; "" otherwise. */
export function describePush(push, t) {
  if (!push || t - push.sim_time_s > PUSH_BEFORE_FALL_S || t < push.sim_time_s) return "";
  const toward = Math.round(push.toward_deg ?? 0);
  const side = { 0: "its front", 90: "its left", 180: "its back", "-180": "its back", "-90": "its right" }[toward];
  const where = side ? ` (${side})` : "";
  return `${(t - push.sim_time_s).toFixed(1)} s after a push of ${push.impulse_n_s.toFixed(2)} N·s toward ${toward}°${where}`;
}

export function describeMotion(m) {
  if (!m) return "—";
  return `a_p ${fmtSigned(m.a_p, 3)}, a_r ${fmtSigned(m.a_r, 3)}, a_y ${fmtSigned(m.a_y, 3)}, CA ${fmtSigned(m.ca, 3)}`;
}

function onState(s) {
  if (s.fell && !fell) {
    fell = { t: s.sim_time_s, motion: params?.motion ?? null, push: describePush(s.push, s.sim_time_s) };
    show();
  } else if (!s.fell && fell) {
    fell = null;
    $("fall-notice").hidden = true;
    document.body.classList.remove("fallen");
  }
}

const same = (a, b) => a && b && ["a_r", "a_p", "a_y", "ca"].every((k) => a[k] === b[k]);

function show() {
  const now = params?.motion ?? null;
  const changed = fell.motion && now && !same(fell.motion, now);
  const after = fell.push ? ` ${fell.push},` : "";
  $("fall-what").textContent = `The robot fell at t = ${fell.t.toFixed(1)} s,${after} walking ${describeMotion(fell.motion)}.`;
  $("fall-now").textContent = changed ? `The motion is now ${describeMotion(now)}: reset to walk it.` : "";
  $("fall-now").hidden = !changed;
  $("fall-reset").textContent = changed ? "Reset and walk the new motion" : "Reset (same motion)";
  $("fall-notice").hidden = false;
  document.body.classList.add("fallen"); // the "walks on the spot" hint would contradict it
}

async function reset(toZero) {
  const msg = $("fall-message");
  try {
    if (toZero) {
      const p = await api.patch("/api/params", { motion: ZERO });
      document.dispatchEvent(new CustomEvent("artro:params", { detail: p }));
    }
    await api.post("/api/sim/reset");
    setMessage(msg, "", "");
  } catch (err) {
    setMessage(msg, err.message, "error");
  }
}
