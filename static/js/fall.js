// After a fall: a notice that names the motion the robot fell with and offers "Reset" (the same
// motion again) and "Reset with motion 0". A motion changed after the fall (undo, a slider, a
// preset) is named too, and the reset button then says it walks the new one: the simulation is
// never left stopped without a word.

import { api } from "./api.js";
import { $, fmtSigned, setMessage } from "./util.js";

const ZERO = { a_r: 0, a_p: 0, a_y: 0, ca: 0 };
let params = null; // the last parameter set announced
let fell = null; // {t, motion} of the fall on screen, or null

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

export function describeMotion(m) {
  if (!m) return "—";
  return `a_p ${fmtSigned(m.a_p, 3)}, a_r ${fmtSigned(m.a_r, 3)}, a_y ${fmtSigned(m.a_y, 3)}, CA ${fmtSigned(m.ca, 3)}`;
}

function onState(s) {
  if (s.fell && !fell) {
    fell = { t: s.sim_time_s, motion: params?.motion ?? null };
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
  $("fall-what").textContent = `The robot fell at t = ${fell.t.toFixed(1)} s, walking ${describeMotion(fell.motion)}.`;
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
