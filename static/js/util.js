// Shared helpers: DOM shortcuts, number formatting, servo names and their colours.

import { pageWords } from "./api.js";

export const $ = (id) => document.getElementById(id);

/** Create an element: h("td", {class: "num"}, "1.0", child, ...). */
export function h(tag, attrs = {}, ...children) {
  const el = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (v == null || v === false) continue;
    if (k === "class") el.className = v;
    else if (k === "text") el.textContent = v;
    else if (k.startsWith("on")) el.addEventListener(k.slice(2), v);
    else el.setAttribute(k, v === true ? "" : v);
  }
  for (const c of children) {
    if (c == null) continue;
    el.append(c instanceof Node ? c : document.createTextNode(String(c)));
  }
  return el;
}

export function fmt(x, digits = 2) {
  if (x == null || Number.isNaN(x)) return "—";
  return Number(x).toFixed(digits);
}

/** A job's time left in words, as the CLI says it (app/evaluation/progress.py `about`):
 *  "~40 s left", "~12 min left", "~2 h 5 min left"; "time left: ~?" before it is known. */
export function aboutLeft(seconds) {
  if (seconds == null || !Number.isFinite(seconds)) return "time left: ~?";
  if (seconds < 90) return `~${Math.round(seconds)} s left`;
  const minutes = Math.round(seconds / 60);
  return minutes < 120 ? `~${minutes} min left` : `~${Math.floor(minutes / 60)} h ${minutes % 60} min left`;
}

/** Signed with an explicit + so direction hints read well: "+0.070". */
export function fmtSigned(x, digits = 3) {
  if (x == null || Number.isNaN(x)) return "—";
  const s = Number(x).toFixed(digits);
  return x > 0 ? `+${s}` : s;
}

/** Hide `el`; a keyboard user whose focus was on it goes on from `next` (not the page's top). */
export function hideKeepingFocus(el, next, how = "hidden") {
  const had = document.activeElement === el;
  if (how === "visibility") el.style.visibility = "hidden";
  else el.hidden = true;
  if (had) next.focus();
}

const EXPIRE_MS = 8000; // an "ok" or "quiet" message goes away after this long
const expiry = new WeakMap();

/** Set a message element's text, in the page's words (`pageWords`), and its state class
 *  ("ok" | "warn" | "error" | "quiet" | "" for neutral). Success and quiet messages expire;
 *  warnings, errors and progress lines stay until replaced. */
export function setMessage(el, text, kind = "") {
  el.textContent = pageWords(text);
  el.classList.remove("ok", "warn", "error", "quiet");
  if (kind) el.classList.add(kind);
  clearTimeout(expiry.get(el));
  if (text && (kind === "ok" || kind === "quiet")) {
    expiry.set(el, setTimeout(() => setMessage(el, "", ""), EXPIRE_MS));
  }
}

// The 12 servos in the joint order of docs/DESIGN.md §3 (left leg first).
export const JOINTS = ["hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll"];
export const SERVOS = [...JOINTS.map((j) => `l_${j}`), ...JOINTS.map((j) => `r_${j}`)];

// One colour per servo (left leg warm/bright, right leg cool), readable on the dark scope.
const PALETTE = [
  "#ff6b6b", "#ffa94d", "#ffd43b", "#a9e34b", "#63e6be", "#f783ac",
  "#4dabf7", "#748ffc", "#b197fc", "#3bc9db", "#e599f7", "#c0eb75",
];
export const servoColor = (name) => PALETTE[Math.max(0, SERVOS.indexOf(name)) % PALETTE.length];

/** "l_ankle_pitch" -> "L AnkP": a short label for narrow slots. */
const SHORT = { hip_yaw: "HipY", hip_roll: "HipR", hip_pitch: "HipP", knee: "Knee", ankle_pitch: "AnkP", ankle_roll: "AnkR" };
export function shortServo(name) {
  if (!name) return "?";
  const side = name[0].toUpperCase();
  return `${side} ${SHORT[name.slice(2)] || name.slice(2)}`;
}

/** "Nice" step for axis ticks: 1, 2 or 5 × 10^n, so that span/step ≈ target ticks. */
export function niceStep(span, target = 6) {
  const raw = Math.abs(span) / Math.max(1, target);
  if (!(raw > 0)) return 1;
  const p = 10 ** Math.floor(Math.log10(raw));
  const m = raw / p;
  return (m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10) * p;
}

/** Size a canvas's backing store to its CSS box × devicePixelRatio; returns the 2D context
 *  already scaled so drawing code works in CSS pixels, plus the CSS width/height. */
export function fitCanvas(canvas) {
  const dpr = window.devicePixelRatio || 1;
  const w = Math.max(1, Math.round(canvas.clientWidth));
  const hgt = Math.max(1, Math.round(canvas.clientHeight));
  if (canvas.width !== Math.round(w * dpr) || canvas.height !== Math.round(hgt * dpr)) {
    canvas.width = Math.round(w * dpr);
    canvas.height = Math.round(hgt * dpr);
  }
  const ctx = canvas.getContext("2d");
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  return { ctx, w, h: hgt };
}

/** A number field's value, or null when it holds none, not a number, or one outside its
 *  min..max (what the page sends is checked as the server would, with the field's words). */
export function fieldNumber(input) {
  const text = input.value.trim();
  const value = Number(text);
  if (!text || input.validity.badInput || !Number.isFinite(value)) return null;
  if (value < Number(input.min) || value > Number(input.max)) return null;
  return input.step === "1" && !Number.isInteger(value) ? null : value;
}

/** What a number field takes, in words: "takes a number 0.01 to 2" ("a whole number" for a
 *  step of 1). */
export function fieldRule(input) {
  const kind = input.step === "1" ? "a whole number" : "a number";
  return `takes ${kind} ${input.min} to ${input.max}`;
}
