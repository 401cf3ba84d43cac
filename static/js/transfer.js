// Export (JSON / YAML / C header, as downloads named by the server) and import of a parameter set.

import { api, locText } from "./api.js";
import { refreshParams } from "./params.js";
import { $, h, setMessage } from "./util.js";

const TYPES = { json: "application/json", yaml: "application/yaml", yml: "application/yaml" };

export function initTransfer() {
  $("import-file").addEventListener("change", async (e) => {
    const file = e.target.files?.[0];
    if (!file) return;
    await importFile(file);
    e.target.value = ""; // so choosing the same file again imports it again
  });
}

async function importFile(file) {
  const msg = $("import-message");
  const ext = file.name.split(".").pop().toLowerCase();
  const type = TYPES[ext] || file.type || "application/octet-stream";
  setMessage(msg, `importing ${file.name}…`, "");
  $("import-problems").replaceChildren();
  $("import-problems").hidden = true;
  try {
    const bytes = await file.arrayBuffer();
    const p = await api.postRaw("/api/import", bytes, type);
    setMessage(msg, `imported '${file.name}' as '${p.name}' — parameters v${p.version}`, "ok");
    refreshParams();
  } catch (err) {
    const what = err.status === 413 ? "too large" : err.status === 422 ? "invalid" : "failed";
    const list = Array.isArray(err.raw) ? err.raw : [];
    if (list.length > 1) {
      // every problem, with where it is in the file; nothing was changed
      setMessage(msg, `${file.name}: not imported, ${list.length} problems (nothing changed):`, "error");
      $("import-problems").replaceChildren(
        ...list.map((p) => h("li", {}, h("code", {}, locText(p.loc) || "file"), `: ${p.msg}`)),
      );
      $("import-problems").hidden = false;
    } else {
      setMessage(msg, `${file.name}: import ${what} (nothing changed): ${err.message}`, "error");
    }
  }
}
