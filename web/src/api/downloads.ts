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

/** An onclick for a link to one of job `jobId`'s files: follows the link `pick` finds in the job read now
 * (the rendered link when the job cannot be read). */
export function followFreshLink(jobId: string, pick: (job: Job) => string | null | undefined, filename: string): (e: Event) => Promise<void> {
  return async (e: Event) => {
    e.preventDefault();
    let url = (e.currentTarget as HTMLAnchorElement).href;
    try {
      url = pick(await api.getJob(jobId)) ?? url;
    } catch { /* keep the rendered link */ }
    save(url, filename);
  };
}
