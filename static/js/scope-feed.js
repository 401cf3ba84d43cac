// The live scope feed: a WebSocket on /ws/scope delivering one JSON frame per 20 ms of sim time.
// Reconnects automatically with a growing back-off; keeps receive statistics (frames per second
// over the last two seconds, frames dropped = gaps in the `frame` numbers). The message handler only
// parses and hands over the frame: drawing happens elsewhere, once per animation frame.

// Exposed for browser tests: the last parsed message and how many arrived.
window.artro = window.artro || {};
window.artro.lastFrame = null;
window.artro.framesReceived = 0;

export class ScopeFeed {
  /** onFrame(frame) for every message; onStatus(text, state) on connection changes. */
  constructor({ onFrame, onStatus }) {
    this.onFrame = onFrame;
    this.onStatus = onStatus;
    this.received = 0;
    this.dropped = 0;
    this.lastNumber = null;
    this.arrivals = []; // performance.now() of the messages of the last 2 s, for frames/s
    this.retryMs = 500;
    this.ws = null;
  }

  url() {
    const proto = location.protocol === "https:" ? "wss:" : "ws:";
    return `${proto}//${location.host}/ws/scope`;
  }

  connect() {
    this.onStatus("connecting…", "wait");
    let ws;
    try {
      ws = new WebSocket(this.url());
    } catch (err) {
      this.scheduleReconnect();
      return;
    }
    this.ws = ws;
    ws.onopen = () => {
      this.retryMs = 500;
      this.lastNumber = null; // frames lost while disconnected are not "dropped" by the link
      this.onStatus("live", "ok");
    };
    ws.onmessage = (ev) => this.handle(ev.data);
    ws.onclose = () => {
      if (this.ws === ws) this.scheduleReconnect();
    };
    ws.onerror = () => ws.close();
  }

  scheduleReconnect() {
    this.ws = null;
    this.onStatus("reconnecting…", "bad");
    setTimeout(() => this.connect(), this.retryMs);
    this.retryMs = Math.min(5000, this.retryMs * 2);
  }

  handle(text) {
    let frame;
    try {
      frame = JSON.parse(text);
    } catch (err) {
      console.warn("scope: bad message", err);
      return;
    }
    this.received++;
    // a gap in the frame numbers = frames the server dropped for us; a smaller number = reset
    if (this.lastNumber != null && frame.frame > this.lastNumber + 1) {
      this.dropped += frame.frame - this.lastNumber - 1;
    }
    this.lastNumber = frame.frame;
    const now = performance.now();
    this.arrivals.push(now);
    while (this.arrivals.length && this.arrivals[0] < now - 2000) this.arrivals.shift();
    window.artro.lastFrame = frame;
    window.artro.framesReceived = this.received;
    this.onFrame(frame);
  }

  /** Messages per second, averaged over the last two seconds (delivery is bursty). */
  fps() {
    const now = performance.now();
    while (this.arrivals.length && this.arrivals[0] < now - 2000) this.arrivals.shift();
    return Math.round(this.arrivals.length / 2);
  }
}
