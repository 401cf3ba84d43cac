// The motion vector and CA as real controls: a slider and a number per field, labelled with what
// a negative and a positive value does (docs/DESIGN.md §3), the known-good band of the loaded preset shaded
// on the track (rule in data/safe-bands.json), arrow keys on a focused slider.
// A change is PATCHed at once (one request in flight, the latest value wins), named with its
// gesture (one drag, one burst of key presses on a slider, one typed value, one Stop): the store
// makes the whole gesture one undo step. Values the server reports are shown unless the user is
// holding that control; the page never writes back what it was told, so nothing echoes
// (docs/DESIGN.md §11).

import { api } from "./api.js";
import { $, fmtSigned, h, setMessage } from "./util.js";

const FIELDS = [
  { key: "a_p", label: "a_p", neg: "◀ backward", pos: "forward ▶" },
  { key: "a_r", label: "a_r", neg: "◀ steps left", pos: "steps right ▶" },
  { key: "a_y", label: "a_y", neg: "↺ turns counter-cw", pos: "turns clockwise ↻" },
  { key: "ca", label: "CA", neg: "↺ right steps longer", pos: "left steps longer ↻" },
];
const HOLD_MS = 800; // after a local edit, server values for that field wait this long
const BURST_MS = 1000; // slider changes closer together than this are one gesture (key repeat)
const PAGE = Math.random().toString(36).slice(2, 10); // this page's gestures are its own

const rows = {}; // key -> {range, number, value, field}
const pending = {};
const lastLocal = {}; // performance.now() of each field's last local edit; none: never edited
let holding = null;
let inFlight = false;
let bands = null;
let current = null; // the last parameters the server reported
let walked = false;
let holdTimer = null;
let gesture = null; // {key, id, at}: the gesture the latest change belongs to
let gestures = 0;
let pendingGesture = null; // the gesture of the changes waiting to be sent

export async function initMotion() {
  // listen before the first await: params.js may announce the set while the schema loads
  document.addEventListener("artro:params", (e) => render(e.detail));
  const [schema, bandFile] = await Promise.all([
    api.get("/api/schema"),
    api.get("/data/safe-bands.json").catch(() => null),
  ]);
  bands = bandFile;
  const fields = Object.fromEntries(schema.find((g) => g.group === "motion").fields.map((f) => [f.name, f]));
  $("motion-rows").replaceChildren(...FIELDS.map((f) => buildRow(f, fields[f.key])));
  $("motion-stop").addEventListener("click", () => {
    startGesture("stop");
    for (const f of FIELDS) send(f.key, 0, "stop");
  });
  window.addEventListener("pointerup", () => (holding = null));
  if (current) render(current); // a set announced before the rows existed
}

function buildRow(f, field) {
  const decimals = Math.max(0, -Math.floor(Math.log10(field.step) + 1e-9));
  const range = h("input", {
    type: "range",
    id: `motion-${f.key}`,
    min: field.min,
    max: field.max,
    step: field.step,
    value: 0,
    "aria-label": `${f.label}: ${f.neg} / ${f.pos}`,
    title: `${field.doc} — eq ${field.eq} [${field.unit}]`,
  });
  const number = h("input", {
    type: "number",
    id: `motion-${f.key}-number`,
    min: field.min,
    max: field.max,
    step: field.step,
    value: 0,
    "aria-label": `${f.label} value`,
  });
  const value = h("span", { class: "motion-band dim", id: `motion-${f.key}-band` });
  const round = (v) => Number(Number(v).toFixed(decimals));
  range.addEventListener("pointerdown", () => {
    holding = f.key;
    startGesture(f.key); // a drag is one gesture, however long
  });
  range.addEventListener("keydown", (e) => onSliderKey(f.key, e));
  range.addEventListener("input", () => {
    number.value = round(range.value);
    send(f.key, round(range.value), f.key);
  });
  number.addEventListener("change", () => {
    const v = Number(number.value);
    const allowed = `${f.label} takes ${field.min} to ${field.max} (${f.neg} … ${f.pos})`;
    if (number.value === "" || number.validity.badInput || !Number.isFinite(v)) {
      refuse(f.key, `${f.label}: not a number, not applied — ${allowed}; it stays ${shown(f.key)}`);
      return;
    }
    if (v < field.min || v > field.max) {
      refuse(f.key, `${f.label}: ${v} not applied — ${allowed}; it stays ${shown(f.key)}`);
      return;
    }
    range.value = number.value;
    startGesture(f.key); // a typed value is a change of its own
    send(f.key, round(number.value), f.key);
  });
  rows[f.key] = { range, number, value, field, decimals };
  return h(
    "div",
    { class: "motion-row", id: `motion-row-${f.key}` },
    h("label", { for: `motion-${f.key}`, class: "motion-label", title: range.title }, f.label),
    h("span", { class: "motion-dir neg" }, f.neg),
    range,
    h("span", { class: "motion-dir pos" }, f.pos),
    number,
    value,
  );
}

function startGesture(key) {
  gesture = { key, id: `${PAGE}-${++gestures}`, at: performance.now() };
  return gesture;
}

/** A key press on a slider: a key held down (auto-repeat) or pressed again within BURST_MS of the
 *  last press on the same slider goes on with the gesture; otherwise a new one begins. */
function onSliderKey(key, event) {
  const going = gesture?.key === key && (event.repeat || event.timeStamp - gesture.at <= BURST_MS);
  if (!going) startGesture(key);
  gesture.at = event.timeStamp;
}

/** The gesture a change of `control` belongs to: the one that control began, else a new one. */
function gestureOf(control) {
  return (gesture?.key === control ? gesture : startGesture(control)).id;
}

function send(key, v, control) {
  lastLocal[key] = performance.now();
  // when the hold ends, what the server has now is shown (an undo during the hold, say)
  clearTimeout(holdTimer);
  holdTimer = setTimeout(() => current && render(current), HOLD_MS + 20);
  pending[key] = v;
  pendingGesture = gestureOf(control);
  markBand(key, v);
  if (control === "stop" && key !== FIELDS[FIELDS.length - 1].key) return; // all four at once
  flush();
}

async function flush() {
  if (inFlight || !Object.keys(pending).length) return;
  const motion = { ...pending };
  for (const k of Object.keys(pending)) delete pending[k];
  inFlight = true;
  try {
    const p = await api.patch("/api/params", { motion }, { "Artro-Gesture": pendingGesture });
    setMessage($("motion-message"), "", "");
    document.dispatchEvent(new CustomEvent("artro:params", { detail: p }));
  } catch (err) {
    setMessage($("motion-message"), `not applied: ${err.message}`, "error");
    for (const k of Object.keys(motion)) showInUse(k); // the server's value again, focused or not
  } finally {
    inFlight = false;
    flush();
  }
}

/** The value in use for `key`, as the server last said. */
const shown = (key) => String(current?.motion?.[key] ?? 0);

/** Put the value in use back into a field's slider and number (also while it has the focus). */
function showInUse(key) {
  const row = rows[key];
  delete lastLocal[key];
  delete pending[key];
  if (!row || !current) return;
  const v = current.motion?.[key] ?? 0;
  row.range.value = v;
  row.number.value = v;
  markBand(key, v);
}

/** A typed value that cannot be applied: say why, and show the value in use again. */
function refuse(key, text) {
  setMessage($("motion-message"), text, "error");
  showInUse(key);
}

function render(p) {
  if (current && p.version < current.version) return; // an older answer overtaken by a newer one
  current = p;
  const now = performance.now();
  for (const f of FIELDS) {
    const row = rows[f.key];
    if (!row) return; // not built yet: initMotion renders `current` when it is
    const v = p.motion?.[f.key] ?? 0;
    // a field never edited here is never busy (performance.now() starts at the page's load, so a
    // default of 0 would hide the server's values for the page's first HOLD_MS)
    const edited = f.key in lastLocal && now - lastLocal[f.key] < HOLD_MS;
    const busy = holding === f.key || edited || f.key in pending;
    if (!busy) {
      row.range.value = v;
      if (document.activeElement !== row.number) row.number.value = v;
      markBand(f.key, v);
    }
  }
  shadeBands(p.name);
  const m = p.motion || {};
  if (m.a_p || m.a_r || m.a_y) walked = true;
  $("first-steps").hidden = walked;
}

function bandFor(name) {
  if (!bands) return null;
  return bands[name] ? { ...bands[name], preset: name } : { ...bands.default, preset: name };
}

function shadeBands(name) {
  const band = bandFor(name);
  for (const f of FIELDS) {
    const { range, value, field } = rows[f.key];
    const [lo, hi] = band?.[f.key] ?? [field.min, field.max];
    const pct = (x) => `${(100 * (x - field.min)) / (field.max - field.min)}%`;
    range.style.setProperty("--lo", pct(lo));
    range.style.setProperty("--hi", pct(hi));
    value.dataset.lo = lo;
    value.dataset.hi = hi;
    value.dataset.measured = band?.verified ? "yes" : "";
    // a band not measured for this set is drawn and named apart from a measured one
    $(`motion-row-${f.key}`).classList.toggle("unmeasured", !band?.verified);
    value.title = band?.verified
      ? `known-good band of '${band.preset}': ${fmtSigned(lo, 2)} … ${fmtSigned(hi, 2)} (artro bench paper)`
      : `'${name}' has no measured band: the shaded ${fmtSigned(lo, 2)} … ${fmtSigned(hi, 2)} is where the built-in presets walk`;
    markBand(f.key, Number(range.value));
  }
}

/** Say whether a value is inside the shaded band. */
function markBand(key, v) {
  const { value } = rows[key];
  const lo = Number(value.dataset.lo);
  const hi = Number(value.dataset.hi);
  if (!Number.isFinite(lo)) return;
  const inside = v >= lo - 1e-9 && v <= hi + 1e-9;
  const band = lo === -hi ? `±${hi}` : `${fmtSigned(lo, 2)}…${fmtSigned(hi, 2)}`;
  const word = value.dataset.measured ? "safe" : "unmeasured";
  value.textContent = inside ? `${word} ${band}` : `⚠ outside ${band}`;
  value.classList.toggle("outside", !inside);
  $(`motion-row-${key}`).classList.toggle("outside", !inside);
}
