// The servo bus of `artro serve --servo-bus pty` (docs/BUS.md), in the status bar from GET
// /api/bus (polled at 1 Hz, only where GET /api/state says `servo_bus`): its
// port, and while a program's goal writes drive the robot "driven by the bus" with the packet
// rate, errors (malformed packets) and the goals' latency to the frame that took them.

import { api, poll } from "./api.js";
import { $, fmt } from "./util.js";

const PROTOCOL = { dynamixel: "Dynamixel 2.0", feetech: "Feetech STS" };

export async function initBusStatus() {
  const state = await api.get("/api/state");
  if (!state.servo_bus) return; // no bus on this server: nothing to ask
  const stop = poll(async () => {
    let bus;
    try {
      bus = await api.get("/api/bus");
    } catch (err) {
      if (err.status === 404) stop(); // no bus on this server
      $("bus-status").hidden = true;
      throw err;
    }
    show(bus);
  }, 1000);
}

function show(bus) {
  const block = $("bus-status");
  block.hidden = false;
  block.classList.toggle("driving", bus.driving);
  $("bus-port").textContent = bus.port;
  $("bus-state").textContent = bus.driving ? "driven by the bus" : "the gait drives";
  $("bus-state").className = `badge ${bus.driving ? "ok" : "neutral"}`;
  const latency = bus.goal_latency_ms_median == null ? "—" : `${fmt(bus.goal_latency_ms_median, 1)} ms`;
  $("bus-traffic").textContent =
    `${fmt(bus.packet_rate_hz, 0)} packets/s · ${bus.errors} error${bus.errors === 1 ? "" : "s"} · ` +
    `latency ${latency}`;
  const malformed = Object.entries(bus.malformed).map(([why, n]) => `${why} ${n}`).join(", ");
  block.title =
    `${PROTOCOL[bus.protocol] || bus.protocol} servos ${bus.ids.join(", ")} at ${bus.baud} baud on ` +
    `${bus.port}: ${bus.packets} packets, ${bus.answers} answers, ${bus.goal_writes} goal writes, ` +
    `${bus.unanswered} to no servo; malformed: ${malformed || "none"}; latency: a goal's last byte ` +
    `to the frame that took it (median, largest ${fmt(bus.goal_latency_ms_max ?? 0, 1)} ms); ` +
    `the latest answer ${bus.answer_late_max_us} µs late at most`;
}
