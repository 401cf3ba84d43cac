// Record and replay: the server keeps the last 60 s (poses, pulses, parameter changes with their
// sources). "Replay" pauses the simulation; the scrub bar moves the 3D view and the scope through
// the recording; Export / VCD download it; Import replays a file exported before.

import { api } from "./api.js";
import { showRecorded } from "./scope-panel.js";
import { note } from "./status.js";
import { $, fmt, hideKeepingFocus, setMessage } from "./util.js";

let active = false;
let seeking = null; // the index being fetched; a newer drag position waits for it
let wanted = null;
let epoch = 0; // counts the user's actions: a poll's answer from before the latest one is stale

export function initReplay() {
  $("replay-enter").addEventListener("click", () => act(() => api.post("/api/recording/replay", {})));
  $("replay-live").addEventListener("click", () => act(() => api.post("/api/recording/live")));
  $("replay-scrub").addEventListener("input", (e) => seek(Number(e.target.value)));
  $("replay-prev").addEventListener("click", () => seek(Number($("replay-scrub").value) - 1));
  $("replay-next").addEventListener("click", () => seek(Number($("replay-scrub").value) + 1));
  $("replay-import").addEventListener("change", importFile);
  setInterval(refresh, 1000);
  refresh();
}

async function act(call) {
  epoch++;
  try {
    show(await call());
    note("");
    setMessage($("replay-message"), "", "");
  } catch (err) {
    note(`replay: ${err.message}`);
  }
}

async function importFile(e) {
  const file = e.target.files[0];
  e.target.value = "";
  if (!file) return;
  const msg = $("replay-message");
  epoch++;
  setMessage(msg, `importing ${file.name}…`, "");
  try {
    show(await api.postRaw("/api/recording/import", await file.text(), "application/json"));
    setMessage(msg, `replaying ${file.name}`, "ok");
  } catch (err) {
    // stays until the next import or replay: a refusal is read at the reader's pace
    setMessage(msg, `${file.name}: not imported, nothing changed — ${err.message}`, "error");
  }
}

/** Move to `index`; while a move is on its way, only the newest asked-for position follows. */
async function seek(index) {
  const scrub = $("replay-scrub");
  if (!active) return;
  index = Math.max(0, Math.min(Number(scrub.max), index));
  scrub.value = String(index);
  if (seeking !== null) {
    wanted = index;
    return;
  }
  seeking = index;
  epoch++;
  try {
    show(await api.post("/api/recording/replay", { index }));
  } catch (err) {
    note(`replay: ${err.message}`);
  } finally {
    seeking = null;
    if (wanted !== null && wanted !== index) {
      const next = wanted;
      wanted = null;
      seek(next);
    }
  }
}

async function refresh() {
  const asked = epoch;
  try {
    const summary = await api.get("/api/recording");
    if (asked !== epoch) return; // asked before an action that changed the replay
    if (summary.replay.active) show(summary.replay, false);
    else {
      if (active) show(summary.replay);
      $("replay-info").textContent = `live · ${fmt(summary.frames * 0.02, 1)} s recorded`;
    }
  } catch {
    /* the status badge reports a lost server */
  }
}

async function show(status, fetchFrame = true) {
  const was = active;
  active = !!status.active;
  $("replay-bar").classList.toggle("active", active);
  // keeps its place (no jump); a focus on it goes on from Replay
  if (active) $("replay-live").style.visibility = "visible";
  else hideKeepingFocus($("replay-live"), $("replay-enter"), "visibility");
  for (const id of ["replay-scrub", "replay-prev", "replay-next"]) $(id).disabled = !active;
  if (!active) {
    if (was) showRecorded(null);
    return;
  }
  const scrub = $("replay-scrub");
  scrub.max = String(status.frames - 1);
  if (seeking === null && document.activeElement !== scrub) scrub.value = String(status.index);
  const from = status.origin === "file" ? "file" : "session";
  $("replay-info").textContent =
    `${from} frame ${status.index + 1}/${status.frames} · t ${fmt(status.t_s, 2)} s · #${status.frame}`;
  if (fetchFrame || !was) showRecorded(await api.get(`/api/recording/frame/${status.index}`));
}
