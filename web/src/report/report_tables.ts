// report.json as tables: mesh stats, warnings, skeleton and skinning quality, motion, refinement, validation, timings.
// The report is free-form JSON written by the pipeline stages, so every section is optional.
import { h } from "../ui/dom";
import { seconds, value } from "../ui/format";

export type Report = Record<string, unknown>;
type Obj = Record<string, unknown>;

const isObj = (v: unknown): v is Obj => typeof v === "object" && v !== null && !Array.isArray(v);
const label = (k: string) => k.replace(/_/g, " ");

/** Two-column table of the scalar entries of `obj` (nested objects and long arrays are left to other tables). */
export function kvTable(obj: Obj, caption?: string, skip: string[] = []): HTMLTableElement {
  const rows = Object.entries(obj).filter(([k, v]) => !skip.includes(k) && !isObj(v) && !(Array.isArray(v) && v.length > 6));
  return h("table", { class: "kv-table" }, caption ? h("caption", { class: "muted", style: "text-align:left" }, caption) : null,
    h("tbody", {}, ...rows.map(([k, v]) => h("tr", {}, h("th", { scope: "row" }, label(k)), h("td", { class: typeof v === "number" ? "num" : "" }, value(v))))));
}

function section(id: string, title: string, ...content: (Node | null)[]): HTMLElement {
  return h("section", { class: "report-section", id: `report-${id}`, "aria-labelledby": `report-${id}-title` },
    h("h3", { id: `report-${id}-title` }, title), ...content);
}

function warnings(report: Report): HTMLElement | null {
  const list = Array.isArray(report.warnings) ? report.warnings : [];
  return section("warnings", `Warnings (${list.length})`,
    list.length ? h("ul", {}, ...list.map((w) => h("li", {}, isObj(w) ? `${w.stage}: ${w.message}` : String(w)))) : h("p", { class: "muted" }, "none"));
}

function skeleton(report: Report): HTMLElement | null {
  const sk = report.skeleton;
  if (!isObj(sk)) return null;
  const parts: (Node | null)[] = [kvTable(sk, undefined, ["timings_s"])];
  for (const [k, v] of Object.entries(sk)) if (isObj(v) && k !== "timings_s") parts.push(kvTable(v, label(k)));
  return section("skeleton", "Skeleton", ...parts);
}

/** skinning.scores: one row per method tried, the chosen one highlighted. */
function skinning(report: Report): HTMLElement | null {
  const sk = report.skinning;
  if (!isObj(sk)) return null;
  const parts: (Node | null)[] = [kvTable(sk)];
  if (isObj(sk.scores)) {
    const methods = Object.entries(sk.scores).filter(([, v]) => isObj(v)) as [string, Obj][];
    const metrics = [...new Set(methods.flatMap(([, v]) => Object.keys(v)))];
    parts.push(h("div", { class: "scroll" }, h("table", { id: "skinning-scores" },
      h("caption", { class: "muted", style: "text-align:left" }, "quality scores per method (lower strain is better; the chosen method is highlighted)"),
      h("thead", {}, h("tr", {}, h("th", {}, "method"), ...metrics.map((m) => h("th", { class: "num" }, label(m))))),
      h("tbody", {}, ...methods.map(([name, s]) => h("tr", { class: name === sk.method ? "best" : "" },
        h("td", {}, name), ...metrics.map((m) => h("td", { class: "num" }, value(s[m])))))))));
  }
  if (isObj(sk.weights)) parts.push(kvTable(sk.weights, "weights"));
  return section("skinning", "Skinning", ...parts);
}

function timings(report: Report): HTMLElement | null {
  const t = report.timings_s;
  if (!isObj(t)) return null;
  const entries = Object.entries(t).filter(([, v]) => typeof v === "number") as [string, number][];
  const total = entries.reduce((a, [, v]) => a + v, 0) || 1;
  return section("timings", "Timings per stage",
    h("table", { id: "timings" }, h("tbody", {}, ...entries.map(([stage, s]) => h("tr", {},
      h("th", { scope: "row" }, stage), h("td", { class: "num" }, seconds(s)),
      h("td", { style: "width:50%" }, h("div", { class: "timing-bar", style: `width:${(100 * s) / total}%` })))),
      h("tr", {}, h("th", { scope: "row" }, "total"), h("td", { class: "num" }, seconds(total)), h("td", {})))));
}

function validation(report: Report): HTMLElement | null {
  const v = report.validation;
  if (!isObj(v)) return null;
  return section("validation", "Format validation",
    h("table", {}, h("thead", {}, h("tr", {}, h("th", {}, "file"), h("th", {}, "validator"), h("th", { class: "num" }, "errors"), h("th", { class: "num" }, "warnings"))),
      h("tbody", {}, ...Object.entries(v).map(([file, r]) => {
        const res = isObj(r) ? r : {};
        return h("tr", {}, h("td", {}, file), h("td", {}, value(res.validator ?? res.skipped)),
          h("td", { class: "num" }, value(res.errors)), h("td", { class: "num" }, value(res.warnings)));
      }))));
}

function generic(report: Report, key: string, title: string): HTMLElement | null {
  const v = report[key];
  if (!isObj(v)) return null;
  const nested = Object.entries(v).filter(([, x]) => isObj(x)).map(([k, x]) => kvTable(x as Obj, label(k)));
  return section(key, title, kvTable(v), ...nested);
}

/** Every known section of the report, in pipeline order, plus the raw JSON. */
export function reportTables(report: Report): HTMLElement {
  const mesh = isObj(report.mesh) ? section("mesh", "Mesh", kvTable(report.mesh)) : null;
  return h("div", { class: "report grid2" },
    h("div", {}, mesh, warnings(report), timings(report)),
    h("div", {}, skeleton(report), skinning(report), generic(report, "weights", "Exported weights"), generic(report, "motion", "Motion"),
      generic(report, "refine", "Physics refinement"), generic(report, "quality", "Quality checks"), validation(report)),
    h("details", { style: "grid-column:1 / -1" }, h("summary", {}, "raw report.json"), h("pre", {}, JSON.stringify(report, null, 2))));
}
