// Small pieces shared by the jobs list and the job detail page: status and warnings badges, progress bar, error line.
import type { Job } from "../api/client";
import { percent } from "./format";
import { h } from "./dom";

export function statusBadge(job: Job): HTMLElement {
  return h("span", { class: `badge ${job.status}`, "data-status": job.status }, job.status);
}

/** "N warnings" (red when one is past a failing threshold), titled with their messages; null without any. */
export function warningsBadge(job: Job): HTMLElement | null {
  const n = job.warnings.length;
  if (!n) return null;
  const hard = job.warnings.some((w) => w.hard);
  return h("span", { class: `warn-badge${hard ? " hard" : ""}`, "data-warnings": String(n),
    title: job.warnings.map((w) => `${w.stage}: ${w.message}`).join("\n") }, `${n} warning${n > 1 ? "s" : ""}`);
}

export function progressBar(job: Job): HTMLElement {
  const done = job.status === "succeeded" ? " done" : job.status === "failed" || job.status === "canceled" ? " failed" : "";
  const pct = Math.round(job.progress * 100);
  return h("div", { class: `progress${done}`, role: "progressbar", "aria-valuemin": "0", "aria-valuemax": "100",
    "aria-valuenow": String(pct), "aria-label": `progress ${pct} %` }, h("span", { style: `width:${pct}%` }));
}

export function stageText(job: Job): string {
  if (job.status === "succeeded") return `done · ${percent(1)}`;
  if (job.status === "queued") return "waiting for a worker";
  return `${job.stage ?? "starting"} · ${percent(job.progress)}`;
}

export function errorLine(job: Job): HTMLElement | null {
  if (!job.error) return null;
  return h("div", { class: "error job-error" }, h("code", {}, job.error.code), ": ", job.error.message);
}
