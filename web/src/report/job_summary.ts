// The job in a few plain sentences, shown at the top of its page: how the skeleton was made and how many joints,
// how it was skinned, what motion was applied, how long it took, and the warnings. The research tables stay below.
import type { Job } from "../api/client";
import { h } from "../ui/dom";
import type { Report } from "./report_tables";

type Obj = Record<string, unknown>;
const obj = (v: unknown): Obj => (typeof v === "object" && v !== null && !Array.isArray(v) ? (v as Obj) : {});
const SKELETON_METHODS: Record<string, string> = {
  humanoid: "fitted a humanoid template", geometric: "traced the mesh's shape", learned: "predicted it with the learned model",
  keep: "kept the upload's own rig", given: "used the edited skeleton you gave",
};

/** Plain-language sentences for a finished job (one per line, only those the report supports). */
export function summaryLines(job: Job, report: Report | null): string[] {
  const r = report ?? {};
  const lines: string[] = [];
  const sk = obj(r.skeleton), skin = obj(r.skinning), motion = obj(r.motion), clip = obj(motion.clip), naming = obj(r.naming);
  if (typeof sk.joints === "number") {
    const how = SKELETON_METHODS[String(sk.method)] ?? `used the ${sk.method} method`;
    const names = typeof naming.preset !== "string" ? ", with the upload's joint names"
      : naming.reading === "structure" ? ", with descriptive joint names" : `, named for ${naming.preset}`;
    const rooted = obj(sk.origin_root).added === true ? ", under a root joint at the file's origin (for root motion; it takes no weight)" : "";
    lines.push(`Skeleton: RigForge ${how}: ${sk.joints} joints${names}${rooted}.`);
  }
  if (typeof skin.method === "string") lines.push(`Skinning: ${skin.method} weights, at most ${skin.max_influences ?? 4} bones per vertex.`);
  if (motion.status === "retargeted") {
    lines.push(`Motion: "${clip.name}" retargeted, ${clip.frames} frames at ${clip.fps} fps (${Number(clip.duration_s).toFixed(2)} s).`);
    const relaxed = obj(motion.relaxation);
    if (typeof relaxed.vertices_moved === "number" && relaxed.vertices_moved > 0) {
      lines.push(`Weights relaxed under the clip at ${relaxed.vertices_moved} vertices, where it crushed or stretched the mesh.`);
    }
  }
  const timings = Object.values(obj(r.timings_s)).filter((t): t is number => typeof t === "number");
  if (timings.length) lines.push(`Took ${timings.reduce((a, b) => a + b, 0).toFixed(1)} s of compute.`);
  const hard = job.warnings.filter((w) => w.hard).length;
  lines.push(job.warnings.length ? `${job.warnings.length} warning${job.warnings.length > 1 ? "s" : ""}${hard ? ` (${hard} past a failing limit)` : ""}: see below.` : "No warnings.");
  return lines;
}

export function jobSummary(job: Job, report: Report | null): HTMLElement {
  return h("section", { id: "job-summary", class: "panel", "aria-label": "summary" },
    ...summaryLines(job, report).map((line) => h("p", { style: "margin:4px 0" }, line)));
}
