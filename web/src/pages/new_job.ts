// New job: drop a mesh (and optional motion), pick options, upload with a progress bar.
// Validation is the server's: problem+json `field` puts the message next to the input it names.
import { ApiError, submitJob, type JobOptionsInput, type Problem } from "../api/client";
import { h, replace } from "../ui/dom";
import { bytes } from "../ui/format";

type Choice = [string, string];

function select(id: string, field: string, choices: Choice[], value: string): HTMLSelectElement {
  return h("select", { id, name: id, "data-field": field }, ...choices.map(([v, label]) => h("option", { value: v, selected: v === value }, label)));
}

function field(label: string, input: HTMLElement, help?: string): HTMLElement {
  const errorId = `${input.id}-error`;
  input.setAttribute("aria-describedby", errorId);
  return h("div", { class: "field" }, h("label", { for: input.id }, label), input,
    help ? h("div", { class: "help" }, help) : null, h("div", { class: "field-error", id: errorId, role: "alert", hidden: true }));
}

function dropZone(id: string, title: string, accept: string, required: boolean, onFile: (f: File | null) => void): { el: HTMLElement; input: HTMLInputElement; clear: () => void } {
  const input = h("input", { type: "file", id, name: id, accept, "data-field": id, "aria-describedby": `${id}-error` });
  const name = h("span", { class: "muted" }, required ? "required" : "optional");
  const set = (f: File | null) => { name.textContent = f ? `${f.name} · ${bytes(f.size)}` : required ? "required" : "optional"; onFile(f); };
  input.addEventListener("change", () => set(input.files?.[0] ?? null));
  const zone = h("label", { class: "dropzone", for: id }, input,
    h("strong", {}, title), h("div", {}, "Drop a file here or ", h("u", {}, "choose one")), name);
  zone.addEventListener("dragover", (e) => { e.preventDefault(); zone.classList.add("over"); });
  zone.addEventListener("dragleave", () => zone.classList.remove("over"));
  zone.addEventListener("drop", (e) => {
    e.preventDefault();
    zone.classList.remove("over");
    const f = e.dataTransfer?.files?.[0];
    if (f) { const dt = new DataTransfer(); dt.items.add(f); input.files = dt.files; set(f); }
  });
  const wrap = h("div", {}, zone, h("div", { class: "field-error", id: `${id}-error`, role: "alert", hidden: true }));
  return { el: wrap, input, clear: () => { input.value = ""; set(null); } };
}

export function newJobPage(root: HTMLElement): () => void {
  let meshFile: File | null = null, motionFile: File | null = null;
  let abort: (() => void) | null = null;
  const mesh = dropZone("mesh", "Mesh", ".glb,.gltf,.zip,.obj,.ply,.stl", true, (f) => { meshFile = f; });
  const motion = dropZone("motion", "Motion (optional)", ".bvh,.glb,.gltf", false, (f) => { motionFile = f; });

  const skeleton = select("opt-skeleton", "options.skeleton", [["auto", "auto (humanoid fit, else geometric)"], ["geometric", "geometric (any creature)"],
    ["humanoid", "humanoid template"], ["keep", "keep the input's skeleton"]], "auto");
  const maxJoints = h("input", { type: "number", id: "opt-max-joints", "data-field": "options.max_joints", value: "64", min: "2", max: "256" });
  const sequenceBones = h("input", { type: "number", id: "opt-sequence-bones", "data-field": "options.sequence_bones", placeholder: "chosen", min: "2", max: "256" });
  const skinning = select("opt-skinning", "options.skinning", [["auto", "auto (best score)"], ["geodesic", "geodesic voxel binding"], ["heat", "heat diffusion"]], "auto");
  const maxInfluences = select("opt-max-influences", "options.max_influences", [["4", "4 (game engines)"], ["8", "8 (film)"]], "4");
  const smooth = h("input", { type: "number", id: "opt-smooth", "data-field": "options.smooth_iterations", value: "8", min: "0", max: "50" });
  const exclude = h("input", { type: "text", id: "opt-exclude", "data-field": "options.exclude_joints", placeholder: "*IK*, *pole*" });
  const clip = h("input", { type: "text", id: "opt-clip", "data-field": "options.motion.clip", placeholder: "first clip" });
  const inPlace = h("input", { type: "checkbox", id: "opt-in-place", "data-field": "options.motion.in_place" });
  const loop = h("input", { type: "checkbox", id: "opt-loop", "data-field": "options.motion.loop" });
  const fps = h("input", { type: "number", id: "opt-fps", "data-field": "options.motion.fps", placeholder: "clip's own", min: "1", max: "240", step: "any" });
  const refine = h("input", { type: "checkbox", id: "opt-refine", "data-field": "options.refine.enabled" });
  const preset = select("opt-preset", "options.refine.preset", [["flesh", "flesh"], ["muscle", "muscle"], ["fat", "fat"], ["rubber", "rubber"], ["stiff", "stiff"]], "flesh");
  const units = select("opt-units", "options.units", [["auto", "auto"], ["m", "metres"], ["cm", "centimetres"], ["mm", "millimetres"], ["in", "inches"]], "auto");
  const naming = select("opt-naming", "options.naming", [["", "default"], ["mixamo", "Mixamo"], ["unreal", "Unreal mannequin"],
    ["unity", "Unity Humanoid"], ["generic", "generic"]], "");
  const fbx = h("input", { type: "checkbox", id: "opt-fbx", "data-field": "options.fbx" });
  const upAxis = select("opt-up", "options.up_axis", [["", "from file"], ["y", "+Y"], ["z", "+Z"], ["-y", "−Y"], ["-z", "−Z"], ["x", "+X"], ["-x", "−X"]], "");

  const bar = h("div", { class: "progress", role: "progressbar", "aria-label": "upload progress", "aria-valuemin": "0", "aria-valuemax": "100", "aria-valuenow": "0" }, h("span", { style: "width:0%" }));
  const barText = h("span", { class: "muted", id: "upload-status" });
  const summary = h("div", { id: "form-errors", role: "alert" });
  const submit = h("button", { type: "submit", class: "primary", id: "submit-job" }, "Upload and rig");
  const cancel = h("button", { type: "button", hidden: true, onclick: () => abort?.() }, "Cancel upload");

  const form = h("form", { class: "newjob", novalidate: true },
    h("div", { class: "grid2", style: "grid-column:1 / -1" }, mesh.el, motion.el),
    h("fieldset", {}, h("legend", {}, "Skeleton"),
      field("Method", skeleton), field("Max joints", maxJoints),
      field("Bones of a mesh sequence", sequenceBones, "rigs from motion: fit this many bones (bones that move alike merge); empty = chosen, up to max joints"),
      field("Units", units, "auto guesses from the size"), field("Up axis", upAxis)),
    h("fieldset", {}, h("legend", {}, "Skinning"),
      field("Method", skinning), field("Max influences", maxInfluences), field("Smoothing passes", smooth),
      field("Leave out joints", exclude, "comma-separated name patterns that get no weight (a kept rig's IK targets)")),
    h("fieldset", {}, h("legend", {}, "Motion (needs a motion file or clips in the mesh)"),
      field("Clip", clip, "name or index; empty = the first clip"), field("Frame rate", fps, "resample to this fps; empty keeps the clip's"),
      field("In place", inPlace, "remove root horizontal travel"), field("Loop", loop)),
    h("fieldset", {}, h("legend", {}, "Physics refinement (PhysRig MLS-MPM)"),
      field("Enabled", refine, "soft-body secondary motion on top of the animation"), field("Material preset", preset)),
    h("fieldset", {}, h("legend", {}, "Export"),
      field("Joint names", naming, "humanoids by engine convention, other creatures descriptive; default: Mixamo names, a kept rig keeps its own"),
      field("FBX", fbx, "also write rigged.fbx / animated.fbx (when the server has Blender's bpy)")),
    h("div", { style: "grid-column:1 / -1" }, summary,
      h("div", { class: "row" }, submit, cancel, h("div", { style: "flex:1" }, bar), barText)));

  const clearErrors = () => {
    summary.replaceChildren();
    for (const el of form.querySelectorAll<HTMLElement>(".field-error")) { el.hidden = true; el.textContent = ""; }
    for (const el of form.querySelectorAll(".invalid, [aria-invalid]")) { el.classList.remove("invalid"); el.removeAttribute("aria-invalid"); }
  };

  const showProblem = (p: Problem) => {
    const target = p.field ? form.querySelector<HTMLElement>(`[data-field="${CSS.escape(p.field)}"]`) : null;
    replace(summary, h("div", { class: "errorbox" }, h("code", {}, p.code), ": ", p.detail));
    if (target) {
      const msg = document.getElementById(`${target.id}-error`)!;
      msg.textContent = p.detail;
      msg.hidden = false;
      target.setAttribute("aria-invalid", "true");
      (target.closest(".dropzone") ?? target).classList.add("invalid");
      target.focus();
    }
  };

  form.addEventListener("submit", async (e) => {
    e.preventDefault();
    clearErrors();
    if (!meshFile) {
      showProblem({ status: 0, code: "missing_mesh", detail: "choose a mesh file to rig", field: "mesh" });
      return;
    }
    const options: JobOptionsInput = {
      skeleton: skeleton.value as JobOptionsInput["skeleton"],
      max_joints: maxJoints.valueAsNumber,
      sequence_bones: sequenceBones.value === "" ? null : sequenceBones.valueAsNumber,
      units: units.value as JobOptionsInput["units"],
      up_axis: (upAxis.value || null) as JobOptionsInput["up_axis"],
      skinning: skinning.value as JobOptionsInput["skinning"],
      max_influences: Number(maxInfluences.value) as 4 | 8,
      smooth_iterations: smooth.valueAsNumber,
      exclude_joints: exclude.value.split(",").map((p) => p.trim()).filter((p) => p !== ""),
      motion: { clip: clip.value === "" ? null : /^\d+$/.test(clip.value) ? Number(clip.value) : clip.value,
        in_place: inPlace.checked, loop: loop.checked, fps: fps.value === "" ? null : fps.valueAsNumber },
      refine: { enabled: refine.checked, preset: preset.value as NonNullable<JobOptionsInput["refine"]>["preset"] },
      naming: (naming.value || null) as JobOptionsInput["naming"],
      fbx: fbx.checked,
    };
    // An emptied number box sends null so the server names the field, rather than silently using a default.
    for (const k of ["max_joints", "smooth_iterations"] as const) if (Number.isNaN(options[k])) (options as Record<string, unknown>)[k] = null;
    submit.disabled = true;
    cancel.hidden = false;
    barText.textContent = "uploading…";
    const setBar = (f: number) => {
      (bar.firstElementChild as HTMLElement).style.width = `${Math.round(f * 100)}%`;
      bar.setAttribute("aria-valuenow", String(Math.round(f * 100)));
      barText.textContent = f < 1 ? `uploading ${Math.round(f * 100)} %` : "checking the upload…";
    };
    const req = submitJob({ mesh: meshFile, motion: motionFile, options }, setBar);
    abort = req.abort;
    try {
      const job = await req.promise;
      barText.textContent = "queued";
      location.hash = `#/jobs/${job.id}`;
    } catch (err) {
      setBar(0);
      barText.textContent = "";
      showProblem(err instanceof ApiError ? err.problem : { status: 0, code: "error", detail: String(err) });
    } finally {
      submit.disabled = false;
      cancel.hidden = true;
      abort = null;
    }
  });

  replace(root, h("h1", {}, "New job"), form);
  return () => abort?.();
}
