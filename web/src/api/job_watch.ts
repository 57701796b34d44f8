// Follow one job live: server-sent events, falling back to polling when the stream fails.
import { api, type Job } from "./client";
import { withKey } from "./session";

const TERMINAL = new Set(["succeeded", "failed", "canceled"]);
const POLL_MS = 1500;

export function isTerminal(job: Job): boolean {
  return TERMINAL.has(job.status);
}

/**
 * Calls `onUpdate` with each new snapshot of the job until it ends; returns a stop function.
 * `useEvents: false` polls only (the jobs list keeps EventSources few: browsers allow ~6 connections per host).
 */
export function watchJob(id: string, onUpdate: (job: Job) => void, useEvents = true): () => void {
  let stopped = false;
  let source: EventSource | null = null;
  let timer: number | undefined;

  const poll = async () => {
    if (stopped) return;
    try {
      const job = await api.getJob(id);
      if (stopped) return;
      onUpdate(job);
      if (isTerminal(job)) return;
    } catch { /* transient: try again */ }
    timer = window.setTimeout(poll, POLL_MS);
  };

  if (useEvents && typeof EventSource !== "undefined") {
    source = new EventSource(withKey(`/api/v1/jobs/${encodeURIComponent(id)}/events`));
    source.addEventListener("job", (e) => {
      const job = JSON.parse((e as MessageEvent).data) as Job;
      onUpdate(job);
      if (isTerminal(job)) { source?.close(); source = null; }
    });
    source.onerror = () => {  // the stream ended early or never opened: poll instead
      source?.close();
      source = null;
      if (!stopped) poll();
    };
  } else {
    poll();
  }
  return () => {
    stopped = true;
    source?.close();
    window.clearTimeout(timer);
  };
}
