// Downloads without the key in any URL: the job's JSON carries short-lived signed links (download_url,
// download_all_url); a click asks the job for fresh ones, since a page may stay open longer than a link lives.
import { api, type Job } from "./client";

function save(url: string, filename: string): void {
  const a = document.createElement("a");
  a.href = url;
  a.download = filename;
  document.body.append(a);
  a.click();
  a.remove();
}

/** Seconds before a signed link expires: ours carry `expires` (Unix seconds), S3's presigned ones X-Amz-Date and
 * X-Amz-Expires; null when the link says neither. */
function secondsLeft(url: string): number | null {
  const q = new URL(url, location.href).searchParams;
  const now = Date.now() / 1000;
  const expires = q.get("expires");
  if (expires !== null) return Number(expires) - now;
  const date = q.get("X-Amz-Date")?.match(/^(\d{4})(\d{2})(\d{2})T(\d{2})(\d{2})(\d{2})Z$/);
  const lifetime = q.get("X-Amz-Expires");
  if (!date || lifetime === null) return null;
  const [, y, mo, d, h, mi, sec] = date.map(Number);
  return Date.UTC(y, mo - 1, d, h, mi, sec) / 1000 + Number(lifetime) - now;
}

const FRESH_ENOUGH_S = 30; // a link with less time left than this is replaced before the browser follows it

/** An onclick for a link to one of job `jobId`'s files: the browser follows the rendered link while it is still
 * valid (a plain click keeps the browser's own download handling); an expiring one is replaced by the link `pick`
 * finds in the job read now (kept when the job cannot be read). */
export function followFreshLink(jobId: string, pick: (job: Job) => string | null | undefined, filename: string): (e: Event) => Promise<void> {
  return async (e: Event) => {
    let url = (e.currentTarget as HTMLAnchorElement).href;
    const left = secondsLeft(url);
    if (left !== null && left > FRESH_ENOUGH_S) return;
    e.preventDefault();
    try {
      url = pick(await api.getJob(jobId)) ?? url;
    } catch { /* keep the rendered link */ }
    save(url, filename);
  };
}
