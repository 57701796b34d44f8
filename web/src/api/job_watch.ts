// Follow one job live: server-sent events read with fetch (so the key travels in the Authorization header, never in
// the URL, unlike EventSource), falling back to polling when the stream fails.
import { EventSourceParserStream } from "eventsource-parser/stream";
import { api, type Job } from "./client";
import { getKey } from "./session";

const TERMINAL = new Set(["succeeded", "failed", "canceled"]);
const POLL_MS = 1500;

export function isTerminal(job: Job): boolean {
  return TERMINAL.has(job.status);
}

/** Reads the job's event stream, calling `onUpdate` per `job` event; resolves when the stream ends, rejects when it fails. */
async function streamEvents(id: string, onUpdate: (job: Job) => void, signal: AbortSignal): Promise<Job | null> {
  const key = getKey();
  const res = await fetch(`/api/v1/jobs/${encodeURIComponent(id)}/events`, {
    headers: { Accept: "text/event-stream", ...(key ? { Authorization: `Bearer ${key}` } : {}) }, signal,
  });
  if (!res.ok || !res.body) throw new Error(`events: HTTP ${res.status}`);
  const events = res.body.pipeThrough(new TextDecoderStream()).pipeThrough(new EventSourceParserStream()).getReader();
  let last: Job | null = null;
  for (;;) {
    const { value, done } = await events.read();
    if (done) return last;
    if (value.event !== "job") continue;
    last = JSON.parse(value.data) as Job;
    onUpdate(last);
  }
}

/**
 * Calls `onUpdate` with each new snapshot of the job until it ends; returns a stop function.
 * `useEvents: false` polls only (the jobs list keeps streams few: browsers allow ~6 connections per host).
 */
export function watchJob(id: string, onUpdate: (job: Job) => void, useEvents = true): () => void {
  let stopped = false;
  let timer: number | undefined;
  const abort = new AbortController();

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

  if (useEvents) {
    streamEvents(id, (job) => { if (!stopped) onUpdate(job); }, abort.signal)
      .then((last) => { if (!stopped && (!last || !isTerminal(last))) poll(); })  // ended early: poll the rest
      .catch(() => { if (!stopped) poll(); });  // never opened or broke off: poll instead
  } else {
    poll();
  }
  return () => {
    stopped = true;
    abort.abort();
    window.clearTimeout(timer);
  };
}
