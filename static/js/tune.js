// "Tune for this robot" (POST /api/jobs/tune): `artro tune --robot`'s recipe on the robot shown,
// in the background, its size set here (generations x candidates, s per run); a progress bar with
// the trials scored, the best loss so far, the generation of how many and the time left; Cancel (DELETE /api/jobs/{id}: nothing loaded).
// Done, the preset tuned-ROBOT is loaded as one undoable change and its figures are shown.

import { api, formatDetail } from "./api.js";
import { jobFollower } from "./job-follow.js";
import { refreshParams } from "./params.js";
import { refreshPresets } from "./presets.js";
import { $, aboutLeft, fieldNumber, fieldRule, fmt, h, hideKeepingFocus, setMessage } from "./util.js";

const tune = jobFollower({ messageId: "tune-message", show, finish }); // the tune followed

export function initTune() {
  $("tune-start").addEventListener("click", start);
  $("tune-cancel").addEventListener("click", tune.cancel);
  tune.watch("tune", running); // a tune started before this page was loaded is followed too
}

async function start() {
  const fields = { generations: "tune-generations", popsize: "tune-popsize", duration_s: "tune-duration" };
  const body = {};
  for (const [key, id] of Object.entries(fields)) {
    body[key] = fieldNumber($(id));
    if (body[key] === null) {
      const label = { generations: "generations", popsize: "candidates", duration_s: "s per run" }[key];
      setMessage($("tune-message"), `not started: ${label} ${fieldRule($(id))}`, "error");
      return;
    }
  }
  try {
    running(await api.post("/api/jobs/tune", body));
    $("tune-figures").hidden = true;
    setMessage($("tune-message"), "");
  } catch (err) {
    setMessage($("tune-message"), formatDetail(err.raw) || err.message, "error");
  }
}

function running(now) {
  tune.job = now;
  $("tune-start").disabled = true;
  $("tune-cancel").hidden = false;
  $("tune-progress-row").hidden = false;
  show(now);
}

function show(now) {
  const d = now.detail || {};
  $("tune-progress").value = now.progress;
  const best = d.best_loss == null ? "—" : fmt(d.best_loss, 3);
  // a candidate is scored once all its runs are walked: the generation's runs show it moving
  const runs = d.runs_total ? ` · generation ${d.generation} of ${d.generations} · run ${d.runs}/${d.runs_total}` : "";
  // the time left of the whole tune, at the pace of its runs so far (app/study/tune.py)
  const left = d.runs_total ? ` · ${aboutLeft(d.left_s).replaceAll(" ", "\u00a0")}` : ""; // one piece
  $("tune-status").textContent = `trials ${d.trials ?? 0}/${d.budget ?? "?"} · best loss ${best}${runs}${left}`;
  $("tune-status").title = d.start ? `from '${d.start}' (its clock scaled to ${d.robot}'s legs); study ${d.study}` : "";
}

function finish(now) {
  if (!tune.job || now.status === "running") return;
  tune.job = null;
  $("tune-start").disabled = false;
  hideKeepingFocus($("tune-cancel"), $("tune-start"));
  const msg = $("tune-message");
  if (now.status === "cancelled") {
    $("tune-progress-row").hidden = true;
    setMessage(msg, "tune cancelled: nothing loaded (its study is kept; a tune of the same size resumes it)", "warn");
  } else if (now.status === "failed") {
    $("tune-progress-row").hidden = true;
    setMessage(msg, `tune failed: ${now.error}`, "error");
  } else {
    const r = now.result;
    const replaced = r.replaced ? ", replacing this robot's earlier tune" : "";
    if (r.applied) {
      setMessage(msg, `'${r.preset}' saved${replaced} and loaded (v${r.params_version}; Undo goes back): loss ${fmt(r.loss, 3)}, every run walked without a fall`);
    } else {
      setMessage(msg, `${r.not_loaded}${replaced} (loss ${fmt(r.loss, 3)})`, "warn");
    }
    figures(r.figures || []);
    refreshPresets();
    refreshParams();
  }
}

/** The paper motions' figures as the tune reports them: speed or turn rate against the target
 *  (scaled to the robot's legs), a CA pair's steering gain and bend against eq (13)'s 1 and 0. */
function figures(rows) {
  $("tune-figures-body").replaceChildren(
    ...rows.map((r) => {
      const fell = r.fell ? "fell" : null;
      const target = r.unit ? `${fmt(r.target, 2)} ${r.unit}` : "gain 1, bend 0";
      const tuned = fell ?? (r.unit ? `${fmt(r.value, 2)} ${r.unit}` : `gain ${fmt(r.gain, 2)}, bend ${fmt(r.bend, 2)}`);
      // within the paper table's 25 % (eq (13)'s 30 %): ok; else off (the tune's own words)
      const mark = fell || r.passes === undefined ? "" : r.passes ? " ok" : " off";
      return h("tr", { "data-run": r.run, "data-passes": String(!!r.passes) },
        h("td", {}, r.run), h("td", { class: "num" }, target),
        h("td", { class: fell ? "num fell" : r.passes === false ? "num off" : "num" }, tuned + mark));
    }),
  );
  $("tune-figures").hidden = !rows.length;
}
