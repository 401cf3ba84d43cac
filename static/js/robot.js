// The robot simulated, and a switch to another (GET /api/robots, PUT /api/robot): the robot starts
// over, standing, in its own preset; the switch is a parameter version, so Undo takes it back.
// A URDF or MJCF (or a zip with its meshes) dropped or picked is imported (POST /api/robot/import),
// its mapping shown, then switched to; refusals are said why, in words.

import { api, formatDetail } from "./api.js";
import { fileDrop } from "./job-follow.js";
import { $, fmt, fmtSigned, h, setMessage } from "./util.js";

/** The server's cap on an upload (app/server/http/robot_upload.py, MAX_UPLOAD_BYTES). */
const MAX_UPLOAD_BYTES = 20 * 1024 * 1024;
const FRONT_FROM = { toes: "its toes", knees: "its knees", given: "the front chosen" };

let offered = [];
let shown = null; // the robot the state last named
let importing = false;
let mappingOf = null; // the robot whose mapping the table shows

export async function initRobot() {
  $("robot-select").addEventListener("change", (e) => switchTo(e.target.value));
  initImport();
  await refreshOffer();
}

/** The robots on offer, into the select (an import adds one). */
async function refreshOffer() {
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
  showLoadedMapping(name);
}

/** The loaded robot's mapping where it was imported from a file (GET /api/robot), else none. */
async function showLoadedMapping(name) {
  let summary;
  try {
    summary = await api.get("/api/robot");
  } catch {
    return; // the figures stay as they were; the next switch asks again
  }
  const cad = summary.description.cad;
  if (summary.name !== name || shown !== name) return; // another switch came meanwhile
  if (mappingOf === name && !$("robot-mapping").hidden) return; // the import's, with its notes
  if (!cad) {
    $("robot-mapping").hidden = true;
    return;
  }
  showMapping({
    robot: name,
    total_mass_kg: summary.total_mass_kg,
    leg_m: summary.derived.leg.upper_m + summary.derived.leg.lower_m,
    file: cad.file.split("/").pop(),
    forward_from: cad.forward_from,
    mapping: Object.entries(summary.mapping).map(([joint, row]) => ({ joint, ...row })),
    notes: [],
    held: cad.held,
  });
}

async function switchTo(name, before = "") {
  const from = shown;
  const msg = $("robot-message");
  const lead = before ? `${before}; ` : "";
  try {
    const done = await api.put("/api/robot", { name });
    const p = done.params;
    showRobot(name);
    setMessage(
      msg,
      done.changed
        ? `${lead}now ${name}: it started over in its preset '${p.name}' (v${p.version}); Undo goes back to ${from}`
        : `${lead}${name} is already simulated`,
      "ok",
    );
    document.dispatchEvent(new CustomEvent("artro:params", { detail: p }));
  } catch (err) {
    $("robot-select").value = from;
    setMessage(msg, `${lead}still ${from}: ${formatDetail(err.raw) || err.message}`, "error");
  }
}

function initImport() {
  fileDrop($("robot-import"), $("robot-import-file"), importFile, {
    messageId: "robot-message",
    what: "file (a .urdf, .xml or .zip)",
  });
  $("robot-import-cancel").addEventListener("click", () => api.del("/api/robot/import").catch(() => {}));
  // a file dropped beside the box would open in the tab instead of the dashboard: it does nothing
  for (const kind of ["dragover", "drop"]) {
    document.addEventListener(kind, (e) => {
      if (e.dataTransfer?.types?.includes("Files")) e.preventDefault();
    });
  }
}

function setImporting(on) {
  importing = on;
  $("robot-import-progress").hidden = !on;
  $("robot-import-cancel").hidden = !on;
  $("robot-import-file").disabled = on;
}

async function importFile(file) {
  if (importing) return;
  const msg = $("robot-message");
  if (file.size > MAX_UPLOAD_BYTES) {
    setMessage(msg, `not imported: ${file.name} has ${file.size} bytes; an upload may have ${MAX_UPLOAD_BYTES}`, "error");
    return;
  }
  setImporting(true);
  $("robot-mapping").hidden = true;
  setMessage(msg, `importing ${file.name}: read by MuJoCo and mapped onto the gait by its geometry…`);
  const query = new URLSearchParams({ filename: file.name });
  if ($("robot-import-forward").value) query.set("forward", $("robot-import-forward").value);
  let done;
  try {
    done = await api.postRaw(`/api/robot/import?${query}`, file, "application/octet-stream");
  } catch (err) {
    setMessage(msg, formatDetail(err.raw) || err.message, "error");
    return;
  } finally {
    setImporting(false);
  }
  showMapping(done);
  await refreshOffer();
  await switchTo(done.robot, `imported ${file.name} as ${done.robot}`);
}

/** An import's mapping: each gait joint's joint in the file, sign, zero and axis error; notes. */
function showMapping(done) {
  mappingOf = done.robot;
  $("robot-mapping-caption").textContent =
    `${done.robot}: ${fmt(done.total_mass_kg, 2)} kg, legs ${fmt(100 * done.leg_m, 1)} cm, ` +
    `from ${done.file}, its front told by ${FRONT_FROM[done.forward_from] || done.forward_from}`;
  $("robot-mapping-table").tBodies[0].replaceChildren(
    ...done.mapping.map((row) =>
      h(
        "tr",
        {},
        h("td", {}, row.joint),
        h("td", { class: "file" }, row.file_joint),
        h("td", { class: "num" }, row.sign > 0 ? "+1" : "−1"),
        h("td", { class: "num" }, fmtSigned(row.zero_rad, 3)),
        h("td", { class: "num" }, `${fmt(row.axis_error_deg, 2)}°`),
      ),
    ),
  );
  const notes = [...done.notes];
  if (done.held.length) notes.push(`held rigid (no leg's): ${done.held.join(", ")}`);
  $("robot-mapping-notes").replaceChildren(...notes.map((n) => h("li", {}, n)));
  $("robot-mapping").hidden = false;
}
