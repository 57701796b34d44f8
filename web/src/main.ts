// Entry point: hash routes → pages. Each page renders into <main> and returns a cleanup function.
import { getKey } from "./api/session";
import { jobDetailPage } from "./pages/job_detail";
import { jobsPage } from "./pages/jobs";
import { keysPage } from "./pages/keys";
import { newJobPage } from "./pages/new_job";
import { refreshWho } from "./ui/who";

export type Cleanup = () => void;
type Page = (root: HTMLElement, param: string) => Cleanup | void;

const routes: [RegExp, string, Page][] = [
  [/^#\/jobs\/([0-9a-f-]{36})$/, "jobs", jobDetailPage],
  [/^#\/jobs$/, "jobs", jobsPage],
  [/^#\/new$/, "new", newJobPage],
  [/^#\/keys$/, "keys", keysPage],
];

let cleanup: Cleanup | void;

function route(): void {
  const main = document.getElementById("main")!;
  cleanup?.();
  cleanup = undefined;
  const hash = location.hash || "#/jobs";
  if (!getKey() && hash !== "#/keys") {
    location.replace("#/keys");  // nothing works without a key: sign in first
    return;
  }
  const match = routes.map(([re, nav, page]) => [re.exec(hash), nav, page] as const).find(([m]) => m);
  main.replaceChildren();
  if (!match) {
    location.replace("#/jobs");
    return;
  }
  const [m, nav, page] = match;
  for (const a of document.querySelectorAll<HTMLAnchorElement>("header nav a")) {
    if (a.dataset.nav === nav) a.setAttribute("aria-current", "page"); else a.removeAttribute("aria-current");
  }
  cleanup = page(main, m![1] ?? "");
}

window.addEventListener("hashchange", route);
route();
refreshWho();
