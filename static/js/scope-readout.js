// The scope panel's readouts: the badge of what it shows (RUN, STOP, REPLAY, FALLEN, PAUSED),
// the receive rate of the feed, and the shown frame's number, time, phase and flags.

import { $, h } from "./util.js";

let flagsKey = "";

/** The badge says what the scope shows: a replay, a frozen picture, a fallen or paused robot (no
 *  new frames come then), or frames as they run. */
export function showRun(state) {
  const [text, kind, title] = state.replaying
    ? ["REPLAY", "warn", "a recorded frame of the replay"]
    : state.frozen
      ? ["STOP", "bad", "frozen: frames keep arriving, the picture stays"]
      : state.sim === "fallen"
        ? ["FALLEN", "bad", "the robot has fallen: no new frames until a reset"]
        : state.sim === "paused"
          ? ["PAUSED", "warn", "the simulation is paused: no new frames until it resumes"]
          : ["RUN", "ok", "frames as the simulation makes them"];
  const run = $("scope-run");
  run.textContent = text;
  run.className = `badge ${kind}`;
  run.title = title;
}

/** The feed's frames per second and frames dropped. */
export function updateFpsReadout(feed) {
  if (!feed) return;
  const el = $("scope-fps");
  el.textContent = `${feed.fps()} fps · ${feed.dropped} dropped`;
  el.title = `frames received per second (averaged over 2 s) and frames lost (gaps in the frame numbers); ${feed.received} received since the page opened`;
}

/** The frame's number, sim time and phase, and its flags (laid out again only when they change). */
export function updateFrameInfo(frame) {
  const info = $("scope-info");
  const flags = $("scope-flags");
  if (!frame) {
    info.textContent = "";
    flags.replaceChildren();
    flagsKey = "";
    return;
  }
  const pins = (frame.source === "firmware" ? " · firmware pins" : "") + (frame.recorded ? " · recorded" : "");
  info.textContent = `#${frame.frame} · ${frame.t_s.toFixed(2)} s · φ ${frame.phase_rad.toFixed(2)}${pins}`;
  info.title = `frame number, sim time and trunk phase φ (rad) of the frame shown; parameters v${frame.params_version ?? "?"}`;
  const f = frame.flags || {};
  const key = JSON.stringify([f.guard_violation, f.saturated, f.glitch, f.stray]);
  if (key === flagsKey) return; // the same flags: the page is not laid out again for them
  flagsKey = key;
  const items = [];
  if (f.guard_violation) items.push(h("span", { class: "flag guard" }, "guard violation"));
  if (f.saturated?.length) items.push(h("span", { class: "flag sat" }, `saturated: ${f.saturated.join(", ")}`));
  if (f.glitch?.length) items.push(h("span", { class: "flag glitch" }, `glitch: ${f.glitch.join(", ")}`));
  if (f.stray?.length) items.push(h("span", { class: "flag glitch" }, `stray: ${f.stray.map((s) => s.join("·")).join(", ")}`));
  if (!items.length) items.push(h("span", { class: "flag none" }, "no flags"));
  flags.replaceChildren(...items);
}
