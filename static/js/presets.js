// Presets: list (built-ins are read-only), load, delete, save the current parameters under a
// name, and the diff of any two (or a preset against "current").

import { api } from "./api.js";
import { refreshParams } from "./params.js";
import { $, h, setMessage } from "./util.js";

// app/params/presets.py's NAME_RULE: 1 to 64 characters, no '..', not ending in '.'
const NAME_RE = /^(?=.{1,64}$)[A-Za-z0-9][A-Za-z0-9_-]*(\.[A-Za-z0-9_-]+)*$/;
const NAME_RULE =
  "a preset name is 1 to 64 characters: letters, digits, '_', '.' and '-', starting with a " +
  "letter or digit, without '..' and not ending in '.'";
const GAIT_RAMP_S = 2; // a new set of gait constants reaches the servos over this (app/server/sim/gait_ramp.py)
let drive = "model";
let engine = null;
let inUse = null; // the name of the set in use: its row is marked
let simulated = null; // the robot the set in use is simulated on
let tunedFor = {}; // preset name -> the robot it was tuned for
let saved = new Set(); // the user's presets (not the built-in ones): a save over one asks first

export function initPresets() {
  document.addEventListener("artro:state", (e) => (drive = e.detail.drive));
  document.addEventListener("artro:params", (e) => {
    engine = e.detail.gait?.engine ?? engine;
    inUse = e.detail.name ?? inUse;
    simulated = e.detail.robot ?? simulated;
    markInUse();
  });
  $("preset-save").addEventListener("click", save);
  $("preset-name").addEventListener("keydown", (e) => e.key === "Enter" && save());
  $("diff-a").addEventListener("change", runDiff);
  $("diff-b").addEventListener("change", runDiff);
  $("diff-run").addEventListener("click", runDiff);
  // "current" changes whenever the parameters do: keep a diff against it up to date
  document.addEventListener("artro:params-version", () => {
    if ($("diff-a").value === "current" || $("diff-b").value === "current") runDiff();
  });
  refreshPresets();
}

export async function refreshPresets() {
  let data;
  try {
    data = await api.get("/api/presets");
  } catch (err) {
    setMessage($("preset-message"), err.message, "error");
    return;
  }
  const list = $("preset-list");
  saved = new Set(data.presets.filter((p) => !p.builtin).map((p) => p.name));
  tunedFor = Object.fromEntries(data.presets.map((p) => [p.name, p.robot]));
  list.replaceChildren(...data.presets.map(row));
  if (!data.presets.length) list.append(h("tr", {}, h("td", { colspan: 4, class: "dim" }, "no presets")));
  const problems = $("preset-problems");
  problems.replaceChildren(...(data.problems || []).map((p) => h("li", {}, `${p.file}: ${p.reason ?? p.error ?? JSON.stringify(p)}`)));
  problems.hidden = !(data.problems || []).length;
  fillDiffSelects(data.presets.map((p) => p.name));
  runDiff();
  markInUse();
}

/** The row of the preset whose name the set in use has (loaded, or tuned here) marked; and a
 * standing note while that preset was tuned for another robot than the one simulated. */
function markInUse() {
  for (const tr of $("preset-list").querySelectorAll("tr[data-preset]")) {
    tr.classList.toggle("in-use", tr.dataset.preset === inUse);
  }
  const other = tunedFor[inUse];
  const note = $("params-robot-note");
  note.hidden = !(other && simulated && other !== simulated);
  if (!note.hidden) {
    note.textContent =
      `⚠ '${inUse}' was tuned for the robot ${other}, not ${simulated}: it may walk differently or ` +
      `fall, and the shaded bands are ${other}'s. Tune for this robot (World panel) or load a set tuned for it.`;
  }
}

function row(p) {
  const load = h("button", { type: "button", class: "small", "data-preset": p.name, "aria-label": `load ${p.name}`, onclick: () => load_(p.name) }, "Load");
  const del = p.builtin
    ? h("span", { class: "badge ro", title: "built in: read-only" }, "read-only")
    : h("button", { type: "button", class: "small danger", "data-preset": p.name, "aria-label": `delete ${p.name}`, onclick: () => remove(p.name) }, "Delete");
  return h(
    "tr",
    { "data-preset": p.name, class: p.builtin ? "builtin" : "" },
    h("td", {}, h("strong", {}, p.name), p.created ? h("div", { class: "dim small" }, p.created.replace("T", " ").slice(0, 19)) : null),
    h("td", { class: "small", title: "the robot this set was tuned for" }, p.robot ?? "—"),
    h("td", { class: "actions" }, load, del),
  );
}

/** How a newly loaded gait reaches the servos (app/server/sim/sim_thread.py). */
function arrival(before, p) {
  if (drive === "firmware") return "the firmware takes the new constants at once";
  if (before && p.gait?.engine !== before) return `the ${p.gait.engine} engine starts up`;
  return `ramped in over ${GAIT_RAMP_S} s, as a change of motion is`;
}

async function load_(name) {
  const keep = $("preset-keep-motion").checked;
  const before = engine;
  try {
    const p = await api.post(`/api/presets/${encodeURIComponent(name)}/load?keep_motion=${keep}`);
    const how = keep ? "its gait, the motion kept" : "its gait and motion";
    const text = `loaded '${name}': ${how}, ${arrival(before, p)} (parameters v${p.version})`;
    const warnings = p.warnings ?? [];
    // a set tuned for another robot: said, and kept in view (a warning does not expire)
    if (warnings.length) setMessage($("preset-message"), `${text}. ⚠ ${warnings.join("; ")}`, "warn");
    else setMessage($("preset-message"), text, "ok");
    refreshParams();
  } catch (err) {
    setMessage($("preset-message"), err.message, "error");
  }
}

async function remove(name) {
  if (!confirm(`Delete preset '${name}'?`)) return;
  try {
    await api.del(`/api/presets/${encodeURIComponent(name)}`);
    setMessage($("preset-message"), `deleted '${name}'`, "ok");
    refreshPresets();
  } catch (err) {
    setMessage($("preset-message"), err.message, "error");
  }
}

async function save() {
  const input = $("preset-name");
  const name = input.value.trim();
  const msg = $("preset-message");
  if (!name) {
    setMessage(msg, "type a name first", "error");
    return;
  }
  // the server decides too; a name it would refuse (or one a URL path would mangle: '/', '..')
  // is not sent
  const bad = !NAME_RE.test(name);
  input.classList.toggle("invalid", bad);
  if (bad) {
    setMessage(msg, `not saved: ${NAME_RULE}`, "error");
    return;
  }
  if (saved.has(name) && !confirm(`Replace your preset '${name}' with the current parameters?`)) {
    setMessage(msg, `not saved: '${name}' is kept as it was`, "ok");
    return;
  }
  try {
    await api.put(`/api/presets/${encodeURIComponent(name)}`);
  } catch (err) {
    setMessage(msg, err.message, "error");
    return;
  }
  input.value = "";
  input.classList.remove("invalid");
  try {  // saved as: the set in use takes the name (one version, the same values; undoable)
    const p = await api.post(`/api/presets/${encodeURIComponent(name)}/load?keep_motion=true`);
    setMessage(msg, `saved the current parameters as '${name}', the set in use now (v${p.version})`, "ok");
    refreshParams();
  } catch (err) {
    setMessage(msg, `saved the current parameters as '${name}' (still in use as before: ${err.message})`, "warn");
  }
  refreshPresets();
}

function fillDiffSelects(names) {
  for (const [id, fallback] of [["diff-a", names[0] ?? "current"], ["diff-b", "current"]]) {
    const sel = $(id);
    const keep = sel.value || fallback;
    sel.replaceChildren(
      h("option", { value: "current" }, "current (in use)"),
      ...names.map((n) => h("option", { value: n }, n)),
    );
    sel.value = ["current", ...names].includes(keep) ? keep : fallback;
  }
}

async function runDiff() {
  const a = $("diff-a").value;
  const b = $("diff-b").value;
  const body = $("diff-body");
  const msg = $("diff-message");
  try {
    const d = await api.get(`/api/presets/diff?a=${encodeURIComponent(a)}&b=${encodeURIComponent(b)}`);
    $("diff-head-a").textContent = a;
    $("diff-head-b").textContent = b;
    body.replaceChildren(
      ...d.differences.map((r) =>
        h("tr", {}, h("td", {}, r.field), h("td", { class: "num" }, show(r.a)), h("td", { class: "num" }, show(r.b))),
      ),
    );
    setMessage(msg, d.differences.length ? `${d.differences.length} field${d.differences.length > 1 ? "s" : ""} differ` : "identical parameters", "");
  } catch (err) {
    body.replaceChildren();
    setMessage(msg, err.message, "error");
  }
}

const show = (v) => (typeof v === "number" ? String(Number(v.toPrecision(6))) : JSON.stringify(v));
