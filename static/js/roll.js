// The roll view's data: a ring buffer of compact per-frame samples (pulse widths, angles,
// saturation) over the last ~10 s; roll-plot.js draws it.

import { SERVOS } from "./util.js";

const N = SERVOS.length;

/** Fixed-capacity ring buffer of per-frame samples {t, frame, phase, us[12], deg[12], sat[12]}. */
export class RollBuffer {
  constructor(capacity = 600) {
    this.capacity = capacity;
    this.items = new Array(capacity);
    this.start = 0;
    this.length = 0;
  }

  clear() {
    this.start = 0;
    this.length = 0;
  }

  last() {
    return this.length ? this.items[(this.start + this.length - 1) % this.capacity] : null;
  }

  push(frame) {
    const prev = this.last();
    // the simulation was reset (time went backwards): start a new recording
    if (prev && frame.t_s < prev.t - 1e-9) this.clear();
    const s = {
      t: frame.t_s,
      frame: frame.frame,
      phase: frame.phase_rad,
      us: new Float32Array(N).fill(NaN),
      deg: new Float32Array(N).fill(NaN),
      sat: new Uint8Array(N),
    };
    for (const ch of frame.channels) {
      for (const slot of ch.slots) {
        const i = SERVOS.indexOf(slot.servo);
        if (i < 0) continue;
        // what the servo actually received (the demultiplexed width) drives the robot
        s.us[i] = slot.decoded_us ?? slot.pulse_us;
        s.deg[i] = slot.deg ?? NaN;
        s.sat[i] = slot.saturated ? 1 : 0;
      }
    }
    if (this.length < this.capacity) {
      this.items[(this.start + this.length) % this.capacity] = s;
      this.length++;
    } else {
      this.items[this.start] = s;
      this.start = (this.start + 1) % this.capacity;
    }
  }

  toArray() {
    const out = new Array(this.length);
    for (let i = 0; i < this.length; i++) out[i] = this.items[(this.start + i) % this.capacity];
    return out;
  }
}
