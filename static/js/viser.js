// The viser 3D view, embedded in an iframe on the same host, at the port /api/health reports.

import { api } from "./api.js";
import { $ } from "./util.js";

const FALLBACK_PORT = 8080; // `artro serve`'s default --viser-port

export async function initViser() {
  const frame = $("viser-frame");
  const note = $("viser-note");
  let port = FALLBACK_PORT;
  let text = "";
  try {
    const health = await api.get("/api/health");
    if (!("viser_port" in health)) {
      text = `The server does not report its 3D-view port; trying ${FALLBACK_PORT}.`;
    } else if (health.viser_port == null) {
      text = "The 3D view is not running (server started with --no-viewer).";
      port = null;
    } else {
      port = health.viser_port;
    }
  } catch (err) {
    text = `Could not ask the server for the 3D-view port (${err.message}); trying ${FALLBACK_PORT}.`;
  }
  if (port != null) {
    const url = `${location.protocol}//${location.hostname}:${port}`;
    frame.src = url;
    $("viser-open").href = url;
    $("viser-open").hidden = false;
  }
  note.textContent = text;
  note.hidden = !text;
}
