// Small pieces shared by the jobs list and the job detail page: status badge, progress bar, error line.
import type { Job } from "../api/client";
import { percent } from "./format";
import { h } from "./dom";

export function statusBadge(job: Job): HTMLElement {
  return h("span", { class: `badge ${job.status}`, "data-status": job.status }, job.status);
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
