// Job detail: live status, artifacts, report tables and the 3D viewer (loaded on demand with three.js).
import { ApiError, api, type Job } from "../api/client";
import { isTerminal, watchJob } from "../api/job_watch";
import { followFreshLink } from "../api/downloads";
import { jobSummary } from "../report/job_summary";
import { reportTables, type Report } from "../report/report_tables";
import { h, replace } from "../ui/dom";
import { bytes, dateTime, duration } from "../ui/format";
import { errorLine, progressBar, stageText, statusBadge, warningsBadge } from "../ui/job_bits";
import type { WorstFrame } from "../viewer/viewer_panel";

function numbers(v: unknown): number[] | null {
  return Array.isArray(v) && v.length > 1 && v.every((x) => typeof x === "number") ? v : null;
}

const figure = (v: number | null | undefined) => (v === null || v === undefined ? "" : Number(v.toPrecision(4)).toString());

/** The quality checks' worst frames as viewer times: frame / the clip's fps (report.motion.clip.fps). */
function worstFrames(job: Job, report: Report | null): WorstFrame[] {
  const clip = (report?.motion as { clip?: { fps?: unknown } } | undefined)?.clip;
  const fps = typeof clip?.fps === "number" ? clip.fps : null;
  if (!fps) return [];
  return job.warnings.filter((w) => w.frame !== null && w.frame !== undefined)
    .map((w) => ({ label: `${w.code} · frame ${w.frame}`, time: (w.frame as number) / fps, model: w.stage === "refine" ? "refined.glb" : "animated.glb" }));
}

export function jobDetailPage(root: HTMLElement, id: string): () => void {
  const head = h("div", { id: "job-head" });
  const facts = h("div", {});
  const summaryHost = h("div", {});
  const warningsHost = h("section", { id: "warnings" });
  const viewerHost = h("section", { id: "viewer", "aria-label": "3D viewer" });
  const artifactsHost = h("section", { id: "artifacts" });
  const reportHost = h("section", { id: "report" });
  replace(root, h("p", {}, h("a", { href: "#/jobs" }, "← Jobs")), head, summaryHost, facts, warningsHost, viewerHost, artifactsHost, reportHost);
  let stopWatch: (() => void) | null = null;
  let disposeViewer: (() => void) | null = null;
  let closed = false;
  let finished = false;

  function renderHead(job: Job): void {
    const cancel = !isTerminal(job) ? h("button", { class: "danger", id: "cancel-job", onclick: async () => {
      try { renderHead(await api.cancelJob(job.id)); } catch (e) { if (e instanceof ApiError) alert(e.message); }
    } }, "Cancel job") : null;
    const finishedActions = isTerminal(job) ? [
      job.download_all_url ? h("a", { class: "button", id: "download-all", href: job.download_all_url, download: `rigforge-${job.id}.zip`,
        onclick: followFreshLink(job.id, (j) => j.download_all_url, `rigforge-${job.id}.zip`) }, "Download all (zip)") : null,
      h("button", { type: "button", id: "rerun-job", onclick: async () => {
        try { location.hash = `#/jobs/${(await api.rerunJob(job.id)).id}`; } catch (e) { if (e instanceof ApiError) alert(e.message); }
      } }, "Re-run"),
      h("button", { type: "button", class: "danger", id: "delete-job", onclick: async () => {
        if (!confirm(`Delete this job and its ${job.artifacts.length} files?`)) return;
        try { await api.deleteJob(job.id); location.hash = "#/jobs"; } catch (e) { if (e instanceof ApiError) alert(e.message); }
      } }, "Delete"),
    ] : [];
    replace(head,
      h("div", { class: "row" }, h("h1", { style: "margin:0" }, job.mesh.filename), statusBadge(job), warningsBadge(job), cancel,
        ...finishedActions),
      h("div", { class: "row", style: "margin:10px 0" }, h("div", { style: "width:320px" }, progressBar(job)),
        h("span", { class: "stage", id: "job-stage" }, stageText(job))),
      job.error ? h("div", { class: "errorbox", id: "job-error" }, h("strong", {}, "Failed: "), errorLine(job)) : null);
    replace(facts, h("dl", { class: "kv panel" },
      h("dt", {}, "Job id"), h("dd", {}, h("code", {}, job.id)),
      h("dt", {}, "Created"), h("dd", {}, dateTime(job.created_at)),
      h("dt", {}, "Ran"), h("dd", {}, job.started_at ? `${dateTime(job.started_at)} · ${duration(job.started_at, job.finished_at)}${job.attempts > 1 ? ` · attempt ${job.attempts}` : ""}` : "not started"),
      h("dt", {}, "Mesh"), h("dd", {}, `${job.mesh.filename} (${job.mesh.format}, ${bytes(job.mesh.size)})`),
      h("dt", {}, "Motion"), h("dd", {}, job.motion ? `${job.motion.filename} (${job.motion.format}, ${bytes(job.motion.size)})` : "none"),
      job.source_job_id ? h("dt", {}, "Re-skin of") : null,
      job.source_job_id ? h("dd", { id: "job-source" }, h("a", { href: `#/jobs/${job.source_job_id}` }, job.source_job_id),
        job.skeleton ? ` with ${job.skeleton.filename}` : "") : null,
      h("dt", {}, "Options"), h("dd", {}, h("details", {}, h("summary", {}, "JSON"), h("pre", {}, JSON.stringify(job.options, null, 2))))));
  }

  function renderWarnings(job: Job): void {
    if (!job.warnings.length) { replace(warningsHost); return; }
    replace(warningsHost, h("h2", {}, "Warnings"), h("table", { id: "warnings-table" },
      h("thead", {}, h("tr", {}, h("th", {}, "Stage"), h("th", {}, "Code"), h("th", {}, "Message"), h("th", { class: "num" }, "Figure"),
        h("th", { class: "num" }, "Threshold"), h("th", { class: "num" }, "Frame"))),
      h("tbody", {}, ...job.warnings.map((w) => h("tr", { "data-code": w.code },
        h("td", {}, w.stage), h("td", { class: w.hard ? "hard" : "" }, h("code", {}, w.code), w.hard ? " (past the failing limit)" : ""),
        h("td", {}, w.message), h("td", { class: "num" }, figure(w.figure)), h("td", { class: "num" }, figure(w.threshold)),
        h("td", { class: "num" }, w.frame === null || w.frame === undefined ? "" : String(w.frame)))))));
  }

  function renderArtifacts(job: Job): void {
    if (!job.artifacts.length) {
      replace(artifactsHost, h("h2", {}, "Artifacts"), h("p", { class: "panel empty" }, isTerminal(job) ? "This job produced no files." : "Files appear here when the job finishes."));
      return;
    }
    replace(artifactsHost, h("h2", {}, "Artifacts"), h("table", { id: "artifacts-table" },
      h("thead", {}, h("tr", {}, h("th", {}, "File"), h("th", {}, "Type"), h("th", { class: "num" }, "Size"), h("th", {}, "SHA-256"), h("th", {}))),
      h("tbody", {}, ...job.artifacts.map((a) => h("tr", {},
        h("td", {}, a.name), h("td", { class: "muted" }, a.media_type), h("td", { class: "num" }, bytes(a.size)),
        h("td", {}, h("code", { title: a.sha256 }, `${a.sha256.slice(0, 12)}…`)),
        h("td", {}, h("a", { href: a.download_url, download: a.name, "aria-label": `Download ${a.name}`,
          onclick: followFreshLink(job.id, (j) => j.artifacts.find((x) => x.name === a.name)?.download_url, a.name) }, "Download")))))));
  }

  async function renderResults(job: Job): Promise<void> {
    renderArtifacts(job);
    const reportArtifact = job.artifacts.find((a) => a.name === "report.json");
    let report: Report | null = null;
    if (reportArtifact) {
      try {
        report = (await api.artifactJson(reportArtifact.url)) as Report;
        replace(reportHost, h("h2", {}, "Report"), h("details", { id: "report-details" },
          h("summary", {}, "Research tables: mesh, skeleton and skinning quality, motion, validation, timings"), reportTables(report)));
      } catch (e) {
        replace(reportHost, h("h2", {}, "Report"), h("div", { class: "errorbox" }, `report.json could not be read: ${e instanceof Error ? e.message : e}`));
      }
    }
    replace(summaryHost, jobSummary(job, report));
    if (closed || !job.artifacts.some((a) => a.name.endsWith(".glb"))) return;
    replace(viewerHost, h("h2", {}, "Viewer"), h("p", { class: "muted" }, "loading the viewer…"));
    const { mountViewer } = await import("../viewer/viewer_panel");
    if (closed) return;
    const refine = report && typeof report.refine === "object" ? (report.refine as Record<string, unknown>) : null;
    const lbs = numbers(refine?.volume_ratio_lbs), refined = numbers(refine?.volume_ratio_refined);
    const host = h("div", {});
    replace(viewerHost, h("h2", {}, "Viewer"), host);
    disposeViewer = mountViewer(host, { artifacts: job.artifacts, volume: lbs && refined ? { lbs, refined } : null,
      worstFrames: worstFrames(job, report), jobId: job.id });
  }

  function update(job: Job): void {
    renderHead(job);
    renderWarnings(job);
    if (isTerminal(job) && !finished) {
      finished = true;
      renderResults(job);
    } else if (!isTerminal(job)) {
      renderArtifacts(job);
    }
  }

  api.getJob(id).then((job) => {
    if (closed) return;
    update(job);
    if (!isTerminal(job)) stopWatch = watchJob(id, update);
  }).catch((e) => {
    replace(head, h("h1", {}, "Job"), h("div", { class: "errorbox" }, e instanceof ApiError ? `${e.code}: ${e.message}` : String(e)));
  });

  return () => { closed = true; stopWatch?.(); disposeViewer?.(); };
}
