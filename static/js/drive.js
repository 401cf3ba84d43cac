// The drive switch in the header: who makes the servo pulses, the Python hardware model or the
// robot's firmware on an emulated ATmega128 (PUT /api/sim/drive). The badge says which is on and
// how busy the emulated MCU is; the select follows the server's state (also a 3D-view switch).

import { api } from "./api.js";
import { note } from "./status.js";
import { $ } from "./util.js";

let switching = false;

export function initDrive() {
  const select = $("drive-select");
  select.addEventListener("change", async () => {
    const drive = select.value;
    switching = true;
    select.disabled = true;
    note(drive === "firmware" ? "building and booting the firmware…" : "", "info");
    try {
      await api.put("/api/sim/drive", { drive });
      note(drive === "firmware" ? "the firmware drives the servos; the robot started over" : "", "info");
    } catch (err) {
      note(`pulses not switched: ${err.message}`);
    } finally {
      switching = false;
      select.disabled = false;
    }
  });
  document.addEventListener("artro:state", (e) => show(e.detail));
}

function show(s) {
  const badge = $("drive-badge");
  const fw = s.firmware;
  badge.hidden = s.drive !== "firmware";
  if (fw) {
    const frameCycles = 320000; // 20 ms at 16 MHz
    const pct = (100 * fw.busy_cycles_max) / frameCycles;
    badge.textContent = `firmware · MCU ${pct.toFixed(0)} %`;
    badge.className = `badge ${fw.busy_cycles_max > fw.busy_budget_cycles ? "warn" : "neutral"}`;
    badge.title =
      `pulses from the firmware on an emulated ATmega128: MCU frame ${fw.mcu_frame}, ` +
      `busy ${fw.busy_cycles_max} cycles of the frame's 320 000 (max over 1 s; budget ` +
      `${fw.busy_budget_cycles}), parameter v${fw.params_version_acked} acknowledged, ` +
      `${fw.sets_in_flight} set(s) on the wire (one at a time: ${fw.sets_skipped} versions ` +
      `replaced by a newer one before they went), ${fw.naks} refused`;
  }
  const select = $("drive-select");
  if (!switching && document.activeElement !== select) select.value = s.drive || "model";
}
