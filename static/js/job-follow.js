// A background job followed on the page (docs/DESIGN.md §10): its state asked at each status
// tick (GET /api/jobs/{id}) and Cancel (DELETE), for the tune and the fit to a recording.

import { api, formatDetail } from "./api.js";
import { $, setMessage } from "./util.js";

/** Follows one job at a time: `show(now)` each answer, `finish(now)` once it stops running;
 * a failed request is said in the element `messageId`. Set `job` to follow one. */
export function jobFollower({ messageId, show, finish }) {
  let asking = false;
  const follower = {
    job: null,
    async follow() {
      if (asking || !follower.job) return;
      asking = true;
      try {
        const now = await api.get(`/api/jobs/${follower.job.id}`);
        show(now);
        if (now.status !== "running") finish(now);
      } catch (err) {
        setMessage($(messageId), err.message, "error");
      } finally {
        asking = false;
      }
    },
    async cancel() {
      if (!follower.job) return;
      try {
        finish(await api.del(`/api/jobs/${follower.job.id}`));
      } catch (err) {
        setMessage($(messageId), formatDetail(err.raw) || err.message, "error");
      }
    },
    /** Follows the job at each state the page reads; the first state names the latest job of
     * `stateKey` ({id, status} | null), one running since before the page was loaded: it is
     * handed to `resume(now)`. */
    watch(stateKey, resume) {
      let seen = false;
      document.addEventListener("artro:state", async (e) => {
        if (follower.job) return follower.follow();
        if (seen) return;
        seen = true;
        const latest = e.detail[stateKey];
        if (latest?.status !== "running") return;
        try {
          resume(await api.get(`/api/jobs/${latest.id}`));
        } catch {
          // it ended meanwhile and was let go: nothing to follow
        }
      });
    },
  };
  return follower;
}

/** `box` takes one file dropped on it and `input` one picked, each handed to `take`; more
 * than one dropped is refused in `messageId`, naming `what` the box takes. */
export function fileDrop(box, input, take, { messageId, what }) {
  input.addEventListener("change", (e) => {
    const file = e.target.files[0];
    e.target.value = ""; // the same file picked again is taken again
    if (file) take(file);
  });
  box.addEventListener("dragover", (e) => {
    e.preventDefault();
    box.classList.add("dropping");
  });
  box.addEventListener("dragleave", () => box.classList.remove("dropping"));
  box.addEventListener("drop", (e) => {
    e.preventDefault();
    box.classList.remove("dropping");
    const files = [...(e.dataTransfer?.files || [])];
    if (files.length !== 1) {
      setMessage($(messageId), `drop one ${what}, not ${files.length}`, "error");
      return;
    }
    take(files[0]);
  });
}
