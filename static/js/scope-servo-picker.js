// The scope's choice of servo lanes: two rows (left leg, right leg) of checkboxes coloured like
// their traces, All and None, and the choice kept in localStorage for the next visit.

import { $, h, JOINTS, SERVOS, servoColor } from "./util.js";

const DEFAULT_SERVOS = ["l_hip_pitch", "l_knee", "r_hip_pitch", "r_knee"];
const STORAGE_KEY = "artro.scope.servos";

/** The servos chosen on the last visit (the default four when none or a damaged entry). */
export function loadServos() {
  try {
    const saved = JSON.parse(localStorage.getItem(STORAGE_KEY));
    if (Array.isArray(saved)) return SERVOS.filter((s) => saved.includes(s));
  } catch {
    /* ignore a damaged entry */
  }
  return [...DEFAULT_SERVOS];
}

/** Two rows (left leg, right leg) of checkboxes, one per joint, coloured like their traces;
 *  `chosen` are ticked; `onChange(servos)` after every change (the choice is saved first). */
export function buildServoPicker(chosen, onChange) {
  const box = $("scope-servos");
  box.replaceChildren();
  const choose = (servos) => {
    localStorage.setItem(STORAGE_KEY, JSON.stringify(servos));
    onChange(servos);
  };
  for (const side of ["l", "r"]) {
    const row = h("div", { class: "servo-row" }, h("span", { class: "servo-side" }, side === "l" ? "Left" : "Right"));
    for (const joint of JOINTS) {
      const name = `${side}_${joint}`;
      const input = h("input", { type: "checkbox", id: `servo-${name}`, value: name, checked: chosen.includes(name) });
      input.addEventListener("change", () => choose(SERVOS.filter((s) => $(`servo-${s}`).checked)));
      row.append(
        h("label", { class: "servo-chip", title: name }, input, h("span", { class: "dot", style: `background:${servoColor(name)}` }), joint),
      );
    }
    box.append(row);
  }
  const all = h("button", { type: "button", class: "small", id: "scope-servos-all" }, "All");
  const none = h("button", { type: "button", class: "small", id: "scope-servos-none" }, "None");
  const setAll = (on) => {
    for (const s of SERVOS) $(`servo-${s}`).checked = on;
    choose(on ? [...SERVOS] : []);
  };
  all.addEventListener("click", () => setAll(true));
  none.addEventListener("click", () => setAll(false));
  box.lastChild.append(h("span", { class: "spacer" }), all, none);
}
