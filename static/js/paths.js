// 2D path plot: the trunk's actual path against the differential-drive prediction (seed 004),
// seen from above. World frame: x forward, y left; drawn with x to the right and y up, so
// counter-clockwise yaw is counter-clockwise on screen. Both axes use the same scale (metres per
// pixel), so circles look like circles.

import { api, poll } from "./api.js";
import { $, fitCanvas, fmt, niceStep, setMessage } from "./util.js";

const COLORS = {
  bg: "#0c1116",
  grid: "rgba(150, 170, 190, 0.12)",
  axis: "rgba(150, 170, 190, 0.35)",
  text: "#9fb0bf",
  actual: "#4dabf7",
  predicted: "#ff922b",
  robot: "#e9f1f7",
  anchor: "#ffd43b",
};
const PAD = { l: 44, r: 12, t: 26, b: 26 };
const MIN_SPAN_M = 0.4;

let last = null;
let fallen = false; // after a fall the measured speeds are the fall's: the readouts go blank

export function initPaths() {
  const canvas = $("path-canvas");
  new ResizeObserver(() => last && draw(last)).observe(canvas);
  $("path-anchor").addEventListener("click", reanchor);
  $("axle-set").addEventListener("click", setAxle);
  $("axle-fit").addEventListener("click", fitAxle);
  document.addEventListener("artro:state", (e) => {
    fallen = !!e.detail.fell;
    if (last) readout(last);
  });
  poll(async () => {
    try {
      last = await api.get("/api/path");
      draw(last);
      readout(last);
    } catch (err) {
      $("path-readout-v").textContent = "—";
      throw err;
    }
  }, 500);
}

async function reanchor() {
  const msg = $("path-message");
  const raw = $("anchor-speed").value.trim();
  let body = {};
  if (raw !== "") {
    const cm = Number(raw);
    if (!Number.isFinite(cm)) {
      setMessage(msg, "V must be a number (cm/s), or empty to measure it", "error");
      return;
    }
    body = { speed_m_s: cm / 100 };
  }
  try {
    await api.post("/api/path/anchor", body);
    setMessage(msg, raw === "" ? "re-anchored; V measured" : `re-anchored with V = ${raw} cm/s`, "ok");
  } catch (err) {
    setMessage(msg, err.message, "error");
  }
}

async function setAxle() {
  const msg = $("path-message");
  const raw = $("axle-cm").value.trim();
  const cm = Number(raw);
  if (raw !== "" && !Number.isFinite(cm)) {
    setMessage(msg, "b must be a number (cm), or empty for the distance between the feet", "error");
    return;
  }
  try {
    await api.put("/api/path/axle", { axle_m: raw === "" ? null : cm / 100 });
    setMessage(msg, raw === "" ? "b = the distance between the feet" : `b = ${raw} cm`, "ok");
  } catch (err) {
    setMessage(msg, err.message, "error");
  }
}

async function fitAxle() {
  const msg = $("path-message");
  const button = $("axle-fit");
  button.disabled = true;
  setMessage(msg, "fitting: simulating CA = -0.1, 0, +0.1 for 20 s each …", "");
  try {
    const r = await api.post("/api/path/axle/fit", {});
    const gain = r.gain == null ? "no steering" : `${fmt(r.gain * 100, 0)} % of eq (13)`;
    const text = r.applied
      ? `b_eff = ${fmt(r.axle_eff_m * 100, 1)} cm (feet ${fmt(r.feet_m * 100, 1)} cm): CA steers at ${gain}`
      : `not applied: ${r.reason}`;
    setMessage(msg, text, r.applied ? "ok" : "error");
  } catch (err) {
    setMessage(msg, err.message, "error");
  } finally {
    button.disabled = false;
  }
}

function readout(p) {
  if (fallen) {
    for (const dd of $("path-readout").querySelectorAll("dd")) dd.textContent = "—";
    return;
  }
  const cms = (v) => (v == null ? "—" : `${fmt(v * 100, 2)} cm/s`);
  $("path-readout-v").textContent = cms(p.speed_m_s);
  $("path-readout-vsrc").textContent = p.speed_source ? `(${p.speed_source})` : "";
  $("path-readout-b").textContent = p.axle_m == null ? "—" : `${fmt(p.axle_m * 100, 1)} cm`;
  $("path-readout-bsrc").textContent = p.axle_source ? `(${p.axle_source})` : "";
  $("path-readout-ca").textContent = fmt(p.ca, 3);
  $("path-readout-r").textContent = p.turn_radius_m == null ? "straight" : `${fmt(p.turn_radius_m, 2)} m`;
  $("path-readout-rate-pred").textContent = `${fmt(p.predicted_turn_deg_s, 2)} °/s`;
  $("path-readout-rate-act").textContent = `${fmt(p.actual_turn_deg_s, 2)} °/s`;
  $("path-readout-fwd").textContent = cms(p.actual_forward_m_s);
  $("path-readout-lat").textContent = cms(p.actual_lateral_m_s);
}

/** Bounds of everything drawn, widened to a minimum span and to the canvas aspect ratio. */
function viewBox(p, w, hgt) {
  const pts = [...(p.actual || []), ...(p.predicted || [])].map((r) => [r[1], r[2]]);
  if (p.anchor) pts.push([p.anchor.x_m, p.anchor.y_m]);
  if (!pts.length) pts.push([0, 0]);
  let [xmin, xmax, ymin, ymax] = [Infinity, -Infinity, Infinity, -Infinity];
  for (const [x, y] of pts) {
    xmin = Math.min(xmin, x);
    xmax = Math.max(xmax, x);
    ymin = Math.min(ymin, y);
    ymax = Math.max(ymax, y);
  }
  const cx = (xmin + xmax) / 2;
  const cy = (ymin + ymax) / 2;
  const pw = w - PAD.l - PAD.r;
  const ph = hgt - PAD.t - PAD.b;
  // equal scaling: one metres-per-pixel for both axes, big enough for the larger extent
  const span = Math.max(MIN_SPAN_M, (xmax - xmin) * 1.15, ((ymax - ymin) * 1.15 * pw) / ph);
  const mPerPx = span / pw;
  return {
    toPx: (x, y) => [PAD.l + pw / 2 + (x - cx) / mPerPx, PAD.t + ph / 2 - (y - cy) / mPerPx],
    xlo: cx - (pw / 2) * mPerPx,
    xhi: cx + (pw / 2) * mPerPx,
    ylo: cy - (ph / 2) * mPerPx,
    yhi: cy + (ph / 2) * mPerPx,
  };
}

function draw(p) {
  const { ctx, w, h } = fitCanvas($("path-canvas"));
  ctx.fillStyle = COLORS.bg;
  ctx.fillRect(0, 0, w, h);
  const vb = viewBox(p, w, h);

  // grid in metres, the same step on both axes
  const step = niceStep(vb.xhi - vb.xlo, 6);
  const digits = step < 0.01 ? 3 : step < 0.1 ? 2 : 1;
  ctx.font = "10px ui-monospace, Menlo, Consolas, monospace";
  ctx.lineWidth = 1;
  for (let x = Math.ceil(vb.xlo / step) * step; x <= vb.xhi; x += step) {
    const [px] = vb.toPx(x, 0);
    ctx.strokeStyle = Math.abs(x) < step / 1e3 ? COLORS.axis : COLORS.grid;
    ctx.beginPath();
    ctx.moveTo(Math.round(px) + 0.5, PAD.t);
    ctx.lineTo(Math.round(px) + 0.5, h - PAD.b);
    ctx.stroke();
    ctx.fillStyle = COLORS.text;
    ctx.textAlign = "center";
    ctx.textBaseline = "top";
    ctx.fillText(label(x, digits), px, h - PAD.b + 5);
  }
  for (let y = Math.ceil(vb.ylo / step) * step; y <= vb.yhi; y += step) {
    const [, py] = vb.toPx(0, y);
    ctx.strokeStyle = Math.abs(y) < step / 1e3 ? COLORS.axis : COLORS.grid;
    ctx.beginPath();
    ctx.moveTo(PAD.l, Math.round(py) + 0.5);
    ctx.lineTo(w - PAD.r, Math.round(py) + 0.5);
    ctx.stroke();
    ctx.fillStyle = COLORS.text;
    ctx.textAlign = "right";
    ctx.textBaseline = "middle";
    ctx.fillText(label(y, digits), PAD.l - 5, py);
  }
  ctx.textAlign = "right";
  ctx.textBaseline = "top";
  ctx.fillText("x (m) →", w - PAD.r, h - 12);
  ctx.textAlign = "left";
  ctx.fillText("↑ y (m)", 4, 6);

  ctx.save();
  ctx.beginPath();
  ctx.rect(PAD.l, PAD.t, w - PAD.l - PAD.r, h - PAD.t - PAD.b);
  ctx.clip();
  polyline(ctx, vb, p.predicted, COLORS.predicted, 2, [6, 4]);
  polyline(ctx, vb, p.actual, COLORS.actual, 1.6, []);
  if (p.anchor) anchorMark(ctx, vb, p.anchor);
  const cur = p.actual?.length ? p.actual[p.actual.length - 1] : null;
  if (cur) robotMark(ctx, vb, cur[1], cur[2], cur[3]);
  ctx.restore();

  // legend
  ctx.font = "11px system-ui, sans-serif";
  ctx.textBaseline = "middle";
  ctx.textAlign = "left";
  const items = [["actual", COLORS.actual, []], ["predicted", COLORS.predicted, [6, 4]], ["anchor", COLORS.anchor, null]];
  const total = items.reduce((a, [t]) => a + 39 + ctx.measureText(t).width, -16);
  let lx = w - PAD.r - total; // right-aligned, clear of the "y (m)" label
  for (const [label, color, dash] of items) {
    ctx.strokeStyle = color;
    ctx.lineWidth = 2;
    if (dash) {
      ctx.setLineDash(dash);
      ctx.beginPath();
      ctx.moveTo(lx, 12);
      ctx.lineTo(lx + 18, 12);
      ctx.stroke();
      ctx.setLineDash([]);
    } else {
      ctx.beginPath();
      ctx.arc(lx + 9, 12, 4, 0, 2 * Math.PI);
      ctx.stroke();
    }
    ctx.fillStyle = COLORS.text;
    ctx.fillText(label, lx + 23, 12);
    lx += 23 + ctx.measureText(label).width + 16;
  }
}

/** Axis label without "-0.00". */
function label(v, digits) {
  const t = v.toFixed(digits);
  return Number(t) === 0 ? (0).toFixed(digits) : t;
}

function polyline(ctx, vb, rows, color, width, dash) {
  if (!rows || rows.length < 2) return;
  ctx.strokeStyle = color;
  ctx.lineWidth = width;
  ctx.lineJoin = "round";
  ctx.setLineDash(dash);
  ctx.beginPath();
  rows.forEach((r, i) => {
    const [px, py] = vb.toPx(r[1], r[2]);
    if (i === 0) ctx.moveTo(px, py);
    else ctx.lineTo(px, py);
  });
  ctx.stroke();
  ctx.setLineDash([]);
}

/** The robot: a triangle pointing along its heading (yaw CCW from +x, so screen angle = −yaw). */
function robotMark(ctx, vb, x, y, yaw) {
  const [px, py] = vb.toPx(x, y);
  ctx.save();
  ctx.translate(px, py);
  ctx.rotate(-yaw);
  ctx.fillStyle = COLORS.robot;
  ctx.strokeStyle = "#000";
  ctx.lineWidth = 1;
  ctx.beginPath();
  ctx.moveTo(11, 0);
  ctx.lineTo(-7, 6.5);
  ctx.lineTo(-4, 0);
  ctx.lineTo(-7, -6.5);
  ctx.closePath();
  ctx.fill();
  ctx.stroke();
  ctx.restore();
}

function anchorMark(ctx, vb, a) {
  const [px, py] = vb.toPx(a.x_m, a.y_m);
  ctx.strokeStyle = COLORS.anchor;
  ctx.lineWidth = 1.5;
  ctx.beginPath();
  ctx.arc(px, py, 6, 0, 2 * Math.PI);
  ctx.moveTo(px - 9, py);
  ctx.lineTo(px + 9, py);
  ctx.moveTo(px, py - 9);
  ctx.lineTo(px, py + 9);
  ctx.stroke();
  // the heading the prediction starts from
  ctx.beginPath();
  ctx.moveTo(px, py);
  ctx.lineTo(px + 18 * Math.cos(a.yaw_rad), py - 18 * Math.sin(a.yaw_rad));
  ctx.stroke();
}
