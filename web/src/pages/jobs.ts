// Jobs: newest first, status filter, cursor pagination, live progress (SSE for a few, polling for the rest).
import { ApiError, api, type Job, type JobStatus } from "../api/client";
import { isTerminal, watchJob } from "../api/job_watch";
import { h, replace } from "../ui/dom";
import { bytes, dateTime, duration } from "../ui/format";
import { errorLine, progressBar, stageText, statusBadge, warningsBadge } from "../ui/job_bits";

const PAGE_SIZES = [10, 20, 50];
const MAX_STREAMS = 3;  // leave the browser's per-host connections for everything else
const STATUSES: (JobStatus | "")[] = ["", "queued", "running", "succeeded", "failed", "canceled"];

export function jobsPage(root: HTMLElement): () => void {
  let status: JobStatus | "" = "";
  const cursors: (string | null)[] = [null];  // cursor of each page visited; the last is the current page
  const watchers = new Map<string, () => void>();
  let refreshTimer: number | undefined;
  let latest = 0;  // only the newest request may render (filter changes can overlap)

  const filter = h("select", { id: "status-filter", onchange: () => { status = filter.value as JobStatus | ""; cursors.length = 1; load(); } },
    ...STATUSES.map((s) => h("option", { value: s, selected: s === status }, s || "all")));
  const size = h("select", { id: "page-size", onchange: () => { cursors.length = 1; load(); } },
    ...PAGE_SIZES.map((n) => h("option", { value: String(n), selected: n === 20 }, String(n))));
  const body = h("div", { "aria-live": "polite" });
  const pager = h("div", { class: "row", style: "margin-top:10px" });
  replace(root,
    h("div", { class: "row", style: "justify-content:space-between" },
      h("h1", {}, "Jobs"),
      h("div", { class: "row" }, h("label", { for: "status-filter" }, "Status"), filter,
        h("label", { for: "page-size" }, "Per page"), size, h("a", { class: "button primary", href: "#/new" }, "New job"))),
    body, pager);

  function stopWatchers(): void {
    for (const stop of watchers.values()) stop();
    watchers.clear();
  }

  function row(job: Job): HTMLTableRowElement {
    const tr = h("tr", { "data-job-id": job.id });
    fill(tr, job);
    return tr;
  }

  function fill(tr: HTMLTableRowElement, job: Job): void {
    replace(tr,
      h("td", {}, h("a", { href: `#/jobs/${job.id}` }, job.mesh.filename), h("div", { class: "muted" }, `${job.mesh.format} · ${bytes(job.mesh.size)}`)),
      h("td", {}, statusBadge(job), " ", warningsBadge(job)),
      h("td", {}, progressBar(job), h("div", { class: "muted stage" }, stageText(job)), errorLine(job)),
      h("td", {}, dateTime(job.created_at)),
      h("td", { class: "num" }, duration(job.started_at, job.finished_at)),
      h("td", { class: "num" }, String(job.artifacts.length)));
  }

  async function load(): Promise<void> {
    stopWatchers();
    window.clearTimeout(refreshTimer);
    const cursor = cursors[cursors.length - 1];
    const mine = ++latest;
    let page;
    try {
      page = await api.listJobs({ status: status || undefined, limit: Number(size.value), cursor: cursor ?? undefined });
      if (mine !== latest) return;
    } catch (e) {
      if (mine !== latest) return;
      replace(body, h("div", { class: "errorbox" }, e instanceof ApiError ? `${e.code}: ${e.message}` : String(e)));
      return;
    }
    if (page.items.length === 0) {
      replace(body, h("div", { class: "panel empty" }, status ? `No ${status} jobs.` : "No jobs yet. ",
        status ? null : h("a", { href: "#/new" }, "Upload a mesh to rig it.")));
    } else {
      const tbody = h("tbody", {}, ...page.items.map(row));
      replace(body, h("table", { id: "jobs-table" },
        h("thead", {}, h("tr", {}, h("th", {}, "Input"), h("th", {}, "Status"), h("th", {}, "Progress"), h("th", {}, "Created"),
          h("th", { class: "num" }, "Duration"), h("th", { class: "num" }, "Artifacts"))), tbody));
      let streams = 0;
      for (const job of page.items.filter((j) => !isTerminal(j))) {
        const tr = tbody.querySelector<HTMLTableRowElement>(`tr[data-job-id="${job.id}"]`)!;
        watchers.set(job.id, watchJob(job.id, (j) => fill(tr, j), streams++ < MAX_STREAMS));
      }
    }
    replace(pager,
      h("button", { disabled: cursors.length === 1, onclick: () => { cursors.pop(); load(); } }, "← Newer"),
      h("button", { disabled: !page.next_cursor, onclick: () => { cursors.push(page.next_cursor); load(); } }, "Older →"),
      h("span", { class: "muted" }, `page ${cursors.length}`));
    // Pick up jobs submitted elsewhere; while rows are live they update themselves (and focus stays put).
    if (cursors.length === 1 && watchers.size === 0) refreshTimer = window.setTimeout(load, 10_000);
    performance.mark("rigforge:interactive");
  }

  load();
  return () => { stopWatchers(); window.clearTimeout(refreshTimer); };
}
