// The A/B ghost panel: a preset or an earlier version walks beside the robot (GET/PUT/DELETE
// /api/ghost). Once a second: the metric deltas (speed, turn rate, gyro RMS over the last 10 s)
// and every parameter in which the ghost differs from the live set.

import { api, poll } from "./api.js";
import { note } from "./status.js";
import { $, fmt, h } from "./util.js";

const METRICS = [
  ["speed_cm_s", "speed, cm/s", 1],
  ["turn_deg_s", "turn rate, °/s (ccw +)", 0],
  ["gyro_rms_deg_s", "gyro RMS, °/s", -1], // lower is steadier
];

let liveName = null; // the name of the parameter set in use
let shownSource = null; // the walking ghost's source the dropdown was last set to
let chosen = false; // the dropdown holds a choice (the user's, or the default offered once)

export function initGhost() {
  document.addEventListener("artro:params", (e) => (liveName = e.detail.name ?? liveName));
  $("ghost-source").addEventListener("change", () => (chosen = true));
  $("ghost-start").addEventListener("click", start);
  $("ghost-stop").addEventListener("click", async () => {
    await api.del("/api/ghost");
    refresh();
  });
  poll(refresh, 1000);
}

async function start() {
  const [kind, value] = $("ghost-source").value.split(":");
  const body = kind === "version" ? { version: Number(value) } : { preset: value };
  try {
    const answer = await api.put("/api/ghost", body);
    const warnings = answer?.warnings ?? [];
    note(warnings.length ? `ghost: ⚠ ${warnings.join("; ")}` : "");
    setTimeout(refresh, 300);
  } catch (err) {
    note(`no ghost: ${err.message}`);
  }
}

let presets = [];
let presetsAt = -Infinity;
const PRESETS_EVERY_MS = 10000; // saved presets change rarely: the list is fetched every 10 s

// who made a version, in the page's words (the store's sources: app/server, `store.update`)
const MADE_BY = {
  http: "edit or undo",
  viser: "3D view",
  "viser-button": "3D view",
  preset: "preset loaded",
  import: "imported",
  robot: "robot switched",
  tune: "tune",
  calibration: "CA calibration",
};
const madeBy = (source) => MADE_BY[source] ?? source;

async function sources(state) {
  const select = $("ghost-source");
  if (document.activeElement === select) return;
  if (performance.now() - presetsAt > PRESETS_EVERY_MS) {
    presets = (await api.get("/api/presets")).presets.map((p) => p.name);
    presetsAt = performance.now();
  }
  const options = [
    ...presets.map((name) => [`preset:${name}`, `preset ${name}`]),
    ...state.versions.slice(1).map((v) => [`version:${v.version}`, `v${v.version} (${madeBy(v.source)})`]),
  ];
  const key = options.map((o) => o[0]).join("|");
  if (select.dataset.key !== key) {
    const keep = select.value;
    select.replaceChildren(...options.map(([value, label]) => h("option", { value }, label)));
    select.dataset.key = key;
    if (options.some((o) => o[0] === keep)) select.value = keep;
  }
  const has = (value) => options.some((o) => o[0] === value);
  const walking = state.enabled ? optionOf(state.source) : null;
  if (walking !== shownSource && has(walking)) {
    select.value = walking; // the dropdown shows what walks beside the robot
    chosen = true;
  } else if (!chosen && !state.enabled && liveName !== null) {
    // a new page: offer a set to compare with, not the one in use
    const other = presets.find((name) => name !== liveName);
    if (other) select.value = `preset:${other}`;
    chosen = true;
  }
  shownSource = walking;
}

/** "preset paper" -> "preset:paper", "version 7" -> "version:7" (the dropdown's values). */
function optionOf(source) {
  const [kind, ...rest] = String(source ?? "").split(" ");
  return kind === "preset" || kind === "version" ? `${kind}:${rest.join(" ")}` : null;
}

async function refresh() {
  const state = await api.get("/api/ghost");
  await sources(state);
  $("ghost-stop").hidden = !state.enabled;
  $("ghost-body").hidden = !state.enabled;
  if (!state.enabled) {
    $("ghost-state").textContent = "no ghost";
    return;
  }
  const lock = state.phase_locked ? "phase-locked" : state.note;
  const fell = state.fell ? " · the ghost has fallen" : "";
  $("ghost-state").textContent = `${state.source} · ${lock}${fell}`;
  const m = state.metrics;
  $("ghost-metrics").replaceChildren(
    ...METRICS.map(([key, label, better]) => {
      const d = m.delta ? m.delta[key] : null;
      const cls = d === null || better === 0 ? "" : d * better > 0 ? "better" : "worse";
      return h(
        "tr",
        { "data-metric": key },
        h("td", {}, label),
        h("td", { class: "num" }, m.live ? fmt(m.live[key]) : "—"),
        h("td", { class: "num" }, m.ghost ? fmt(m.ghost[key]) : "—"),
        h("td", { class: `num ghost-delta ${cls}` }, d === null ? `— (${fmt(state.window_s, 1)} s)` : (d > 0 ? "+" : "") + fmt(d)),
      );
    }),
  );
  $("ghost-diff").replaceChildren(
    ...(state.diff.length
      ? state.diff.map((d) => h("tr", {}, h("td", {}, d.field), h("td", { class: "num" }, String(d.live)), h("td", { class: "num" }, String(d.ghost))))
      : [h("tr", {}, h("td", { colspan: 3, class: "dim" }, "the same parameters"))]),
  );
}
