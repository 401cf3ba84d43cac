// The servo bus of a robot whose servos sit on one (docs/BUS.md): each frame's sync write, shown
// under the scope where a TDM-PWM robot shows its pulses: the packet's time on the wire within the
// 20 ms frame, its bytes, the physics step its goals act at, and each servo's goal.

import { $, fmt, h } from "./util.js";

const FRAME_US = 20000;
const PROTOCOL = { dynamixel: "Dynamixel 2.0", feetech: "Feetech STS" };
const PACKET_SHOWN = 48; // bytes of the packet written out; the rest is counted

/** Show `frame.bus` (or hide the strip for a TDM-PWM robot). */
export function showBus(frame) {
  const strip = $("scope-bus");
  const bus = frame?.bus;
  strip.hidden = !bus;
  const mega = frame?.pca9685 ? "PCA9685 and I²C scope (Mega board)" : "TDM-PWM scope";
  $("scope-title").textContent = bus ? "Servo bus and scope" : mega;
  if (!bus) return;
  const bytes = bus.packet.split(" ");
  const rest = bytes.length > PACKET_SHOWN ? ` … (${bytes.length - PACKET_SHOWN} more)` : "";
  const packet = h("div", { class: "bus-packet" });
  packet.style.width = `${(100 * bus.wire_us) / FRAME_US}%`;
  strip.replaceChildren(
    h(
      "div",
      { class: "bus-line" },
      `${PROTOCOL[bus.protocol] || bus.protocol} sync write: ${bus.bytes} bytes, ` +
        `${fmt(bus.wire_us / 1000, 2)} ms on the wire at ${fmt(bus.baud / 1e6, 3)} Mbit/s; ` +
        `every goal acts at step ${bus.step} of the frame (no pulses: the TDM lines stay low)`,
    ),
    h(
      "div",
      { class: "bus-wire", title: "the frame's 20 ms, the sync write's time on the wire shaded" },
      packet,
    ),
    h(
      "div",
      { class: "bus-goals" },
      ...bus.goals.map((g) =>
        h(
          "span",
          { class: "bus-goal", title: `ID ${g.id}: goal ${g.steps} of 4096 steps a turn` },
          `${g.servo} #${g.id} ${g.steps} (${fmt(g.deg, 1)}°)`,
        ),
      ),
    ),
    h("div", { class: "bus-bytes mono" }, bytes.slice(0, PACKET_SHOWN).join(" ") + rest),
  );
}
