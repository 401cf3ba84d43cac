// The note under each slot of a TDM line (servo, pulse width, angle): one wording for the whole
// frame, the longest that fits every slot, and the µs / degree formats the servo lanes share.

import { THEME } from "./scope-theme.js";
import { servoColor, shortServo } from "./util.js";

export const fmtUs = (us) => (us == null ? "—" : `${Number(us).toFixed(1)}µs`);
export const fmtDeg = (d) => (d == null ? "" : `${d >= 0 ? "+" : ""}${Number(d).toFixed(1)}°`);

/** The wordings of a slot's note, longest first: servo (name or short), pulse width, angle. */
export const NOTE_FORMS = [
  (n) => [n.name, `${n.us} ${n.deg}`],
  (n) => [n.short, `${n.us} ${n.deg}`],
  (n) => [n.name, n.us, n.deg],
  (n) => [n.short, n.us, n.deg],
  (n) => [`${n.short} ${n.deg}`, n.us],
  (n) => [n.short, n.us],
  (n) => [n.us],
];
const NOTE_LINE_H = 11;

export const noteWords = (s) => ({
  name: s.servo ?? "stray", short: shortServo(s.servo), us: fmtUs(s.pulse_us), deg: fmtDeg(s.deg),
});

/** One wording for every slot note of the frame: the longest form that fits each slot's width
 *  and the lines below its trace, so the labels never mix two styles. notes: [{s, width, height}]. */
export function noteForm(ctx, notes) {
  ctx.font = THEME.small;
  const fits = (form, { s, width, height }) => {
    const words = NOTE_FORMS[form](noteWords(s));
    const rows = Math.max(1, Math.floor(height / NOTE_LINE_H));
    return words.length <= rows && words.every((t) => ctx.measureText(t).width <= width - 6);
  };
  const form = NOTE_FORMS.findIndex((_, f) => notes.every((n) => fits(f, n)));
  return form < 0 ? NOTE_FORMS.length - 1 : form;
}

/** Annotate one slot of a TDM line with servo, pulse width and angle in the frame's form. */
export function slotNote(ctx, s, xLeft, yTop, form) {
  const chosen = NOTE_FORMS[form](noteWords(s));
  ctx.font = THEME.small;
  const color = s.guard_violation ? THEME.guard : s.saturated ? THEME.sat : THEME.text;
  ctx.textAlign = "left";
  ctx.textBaseline = "top";
  chosen.forEach((t, i) => {
    ctx.fillStyle = i === 0 ? (s.servo ? servoColor(s.servo) : THEME.glitch) : color;
    ctx.fillText(t, xLeft + 4, yTop + i * NOTE_LINE_H);
  });
}
