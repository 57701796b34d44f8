// The viewer's controls around the canvas: model choice (incl. LBS vs physics), colour mode, bone picking,
// skeleton overlay, pose test, animation playback and the volume-change plot. Loaded lazily with three.js.
import { api, type Artifact } from "../api/client";
import { volumePlot, type VolumePlot } from "../report/volume_plot";
import { h, replace } from "../ui/dom";
import { posePanel } from "./pose_panel";
import { rigEditor } from "./rig_editor";
import { SceneView, type ColorMode, type LoadedModel } from "./scene_view";

const COMPARE = "__compare__";
const LABELS: Record<string, string> = { "animated.glb": "LBS", "refined.glb": "Physics (MPM)", "rigged.glb": "Rigged", "mesh.glb": "Ingested mesh" };

declare global {
  interface Window { rigforgeViewer?: { view: SceneView; state: string; jointScreenPoints: () => ReturnType<SceneView["jointScreenPoints"]> } }
}

/** A quality check's worst moment: `time` seconds into the clip of `model` (animated.glb or refined.glb). */
export interface WorstFrame { label: string; time: number; model: string }

export interface ViewerInput {
  artifacts: Artifact[];
  volume?: { lbs: number[]; refined: number[] } | null;
  worstFrames?: WorstFrame[];
  jobId?: string;  // the job shown: its skeleton can be edited and re-skinned as a new job
}

export function mountViewer(host: HTMLElement, input: ViewerInput): () => void {
  const glbs = input.artifacts.filter((a) => a.name.endsWith(".glb"));
  const byName = new Map(glbs.map((a) => [a.name, a]));
  const canCompare = byName.has("animated.glb") && byName.has("refined.glb");
  const preferred = canCompare ? COMPARE : ["animated.glb", "rigged.glb", "mesh.glb"].find((n) => byName.has(n)) ?? glbs[0]?.name ?? "";

  const canvas = h("canvas", { id: "viewer-canvas", tabindex: "0", "aria-label": "3D view: drag to orbit, scroll to zoom, click a joint or the mesh to show that bone's weights" });
  const tip = h("div", { class: "tip", hidden: true });
  const labels = h("div", { class: "labels" });
  const status = h("div", { class: "status", id: "viewer-status", "aria-live": "polite" }, "loading…");
  const stage = h("div", { class: "stage", "data-state": "loading", id: "viewer-stage" }, canvas, labels, tip, status);
  const view = new SceneView(canvas);
  window.rigforgeViewer = { view, state: "loading", jointScreenPoints: () => view.jointScreenPoints() };

  const modelSelect = h("select", { id: "viewer-model" },
    canCompare ? h("option", { value: COMPARE }, "LBS vs physics, side by side") : null,
    ...glbs.map((a) => h("option", { value: a.name }, `${a.name}${LABELS[a.name] ? ` (${LABELS[a.name]})` : ""}`)));
  modelSelect.value = preferred;
  const toggle = canCompare ? h("button", { type: "button", id: "viewer-toggle", title: "switch between LBS and physics-refined (keeps the time)",
    onclick: () => { modelSelect.value = modelSelect.value === "refined.glb" ? "animated.glb" : "refined.glb"; showSelection(); } }, "Toggle LBS / physics") : null;
  const urlInput = h("input", { type: "url", id: "viewer-url", placeholder: "/path/or/url/to/model.glb", style: "width:100%" });
  const fileInput = h("input", { type: "file", id: "viewer-file", accept: ".glb" });

  const modeRadios = (["texture", "weights", "dominant"] as ColorMode[]).map((mode) => h("input", { type: "radio", name: "viewer-color", id: `viewer-color-${mode}`,
    value: mode, checked: mode === "texture", onchange: () => { view.setColorMode(mode); legend.hidden = mode !== "weights"; } }));
  const modeLabels = { texture: "Textured", weights: "Weights of the selected bone", dominant: "Dominant bone" };
  const boneSelect = h("select", { id: "viewer-bone", onchange: () => selectBone(boneSelect.value || null) });
  const skeletonBox = h("input", { type: "checkbox", id: "viewer-skeleton", checked: true, onchange: () => view.setSkeletonVisible(skeletonBox.checked) });
  const pose = posePanel(view, () => setPlaying(false));
  const editor = input.jobId ? rigEditor(view, input.jobId, input.artifacts) : null;
  const legend = h("div", { hidden: true }, h("div", { class: "legend" }), h("div", { class: "legend-labels" }, h("span", {}, "0"), h("span", {}, "0.5"), h("span", {}, "1")));

  const clipSelect = h("select", { id: "viewer-clip", onchange: () => { view.setClip(clipSelect.value || null); syncTime(); } });
  const playButton = h("button", { type: "button", id: "viewer-play", onclick: () => setPlaying(!view.playing) }, "Play");
  const scrub = h("input", { type: "range", id: "viewer-scrub", min: "0", max: "1", step: "0.001", value: "0", "aria-label": "animation time",
    oninput: () => { setPlaying(false); view.setTime(Number(scrub.value) * view.duration()); syncTime(); } });
  const followBox = h("input", { type: "checkbox", id: "viewer-follow", checked: true, onchange: () => { view.follow = followBox.checked; } });
  const timeText = h("span", { class: "muted", id: "viewer-time" }, "0.00 s");
  const worst = (input.worstFrames ?? []).filter((w) => byName.has(w.model));
  const worstButtons = worst.map((w, i) => h("button", { type: "button", class: "worst-frame", id: `viewer-worst-${i}`,
    title: `show ${w.model} at ${w.time.toFixed(2)} s`, onclick: () => showWorst(w) }, w.label));
  const plot: VolumePlot | null = input.volume ? volumePlot(input.volume.lbs, input.volume.refined) : null;

  let disposed = false;
  const cache = new Map<string, Promise<LoadedModel>>();
  const loadArtifact = (name: string) => {
    if (!cache.has(name)) cache.set(name, api.artifactBytes(byName.get(name)!.url).then((b) => view.load(b, LABELS[name] ?? name)));
    return cache.get(name)!;
  };

  function setPlaying(on: boolean): void {
    view.playing = on && view.duration() > 0;
    playButton.textContent = view.playing ? "Pause" : "Play";
    playButton.setAttribute("aria-pressed", String(view.playing));
  }

  function syncTime(): void {
    const d = view.duration();
    scrub.value = String(d > 0 ? view.time / d : 0);
    timeText.textContent = `${view.time.toFixed(2)} / ${d.toFixed(2)} s`;
    plot?.setCursor(d > 0 ? view.time / d : 0);
  }
  view.onTime = syncTime;

  function selectBone(name: string | null): void {
    view.selectBone(name);
    pose.select(name);
    boneSelect.value = name ?? "";
    if (name && view.colorMode !== "weights") { modeRadios[1].checked = true; view.setColorMode("weights"); legend.hidden = false; }
    status.textContent = name ? `bone ${name}: weights shown from 0 (blue) to 1 (red)` : describe();
  }

  function describe(): string {
    const m = view.models;
    const verts = m.reduce((a, x) => a + x.vertices, 0), bones = view.boneNames().length;
    return `${verts.toLocaleString()} vertices · ${bones ? `${bones} bones · click a joint or the mesh to see its weights` : "no skin in this file"}`;
  }

  async function show(models: Promise<LoadedModel>[], names: string[]): Promise<void> {
    stage.dataset.state = "loading";
    window.rigforgeViewer!.state = "loading";
    editor?.close();
    status.textContent = `loading ${names.join(" and ")}…`;
    try {
      const loaded = await Promise.all(models);
      if (disposed) return;  // the page moved on while the models loaded
      const keep = view.time;
      view.show(loaded);
      pose.reset();
      pose.select(view.boneNames().includes(view.selectedBone ?? "") ? view.selectedBone : null);
      if (keep > 0) view.setTime(Math.min(keep, view.duration()));
      replace(labels, ...(loaded.length > 1 ? loaded.map((m) => h("span", {}, m.label)) : []));
      replace(boneSelect, h("option", { value: "" }, view.boneNames().length ? "— none —" : "no skeleton"),
        ...view.boneNames().map((n) => h("option", { value: n }, n)));
      boneSelect.value = view.selectedBone ?? "";
      boneSelect.disabled = skeletonBox.disabled = view.boneNames().length === 0;
      for (const r of modeRadios.slice(1)) r.disabled = view.boneNames().length === 0;
      const clips = view.clipNames();
      replace(clipSelect, ...(clips.length ? clips.map((c) => h("option", { value: c }, c)) : [h("option", { value: "" }, "no animation")]));
      clipSelect.disabled = playButton.disabled = scrub.disabled = clips.length === 0;
      setPlaying(false);
      syncTime();
      status.textContent = view.selectedBone ? `bone ${view.selectedBone}` : describe();
      stage.dataset.state = "ready";
      window.rigforgeViewer!.state = "ready";
    } catch (err) {
      if (disposed) return;
      status.textContent = `could not load: ${err instanceof Error ? err.message : err}`;
      stage.dataset.state = "error";
      window.rigforgeViewer!.state = "error";
    }
  }

  async function showWorst(w: WorstFrame): Promise<void> {
    if (modelSelect.value !== COMPARE && modelSelect.value !== w.model) { modelSelect.value = w.model; showSelection(); }
    await loadArtifact(w.model);
    setPlaying(false);
    view.setTime(Math.min(w.time, view.duration()));
    syncTime();
  }

  function showSelection(): void {
    const v = modelSelect.value;
    if (v === COMPARE) show([loadArtifact("animated.glb"), loadArtifact("refined.glb")], ["animated.glb", "refined.glb"]);
    else if (v) show([loadArtifact(v)], [v]);
  }
  modelSelect.addEventListener("change", showSelection);

  const loadOther = async (bytes: Promise<ArrayBuffer>, name: string) => show([bytes.then((b) => view.load(b, name))], [name]);
  const urlForm = h("form", { class: "row", onsubmit: (e: Event) => {
    e.preventDefault();
    const url = urlInput.value.trim();
    if (!url) return;
    // Same-origin URLs (artifacts of other jobs) are fetched with the signed-in key.
    const same = new URL(url, location.href).origin === location.origin;
    loadOther(same ? api.artifactBytes(url) : fetch(url).then((r) => { if (!r.ok) throw new Error(`HTTP ${r.status}`); return r.arrayBuffer(); }), url.split("/").pop() ?? url);
  } }, urlInput, h("button", { type: "submit" }, "Open"));
  fileInput.addEventListener("change", () => { const f = fileInput.files?.[0]; if (f) loadOther(f.arrayBuffer(), f.name); });

  // Click (not drag) on the canvas: a joint selects its bone; otherwise the bone that most moves the clicked triangle.
  let down: { x: number; y: number } | null = null;
  canvas.addEventListener("pointerdown", (e) => { down = { x: e.offsetX, y: e.offsetY }; });
  canvas.addEventListener("pointerup", (e) => {
    if (!down || Math.hypot(e.offsetX - down.x, e.offsetY - down.y) > 4) return;
    const joint = view.pickJoint(e.offsetX, e.offsetY);
    const name = joint?.name ?? view.pickSurfaceBone(e.offsetX, e.offsetY);
    if (name) selectBone(name);
  });
  canvas.addEventListener("pointermove", (e) => {
    if (e.buttons) return;
    const joint = view.pickJoint(e.offsetX, e.offsetY);
    view.setHover(joint?.name ?? null);
    tip.hidden = !joint;
    if (joint) { tip.textContent = joint.name; tip.style.left = `${e.offsetX}px`; tip.style.top = `${e.offsetY}px`; }
  });
  canvas.addEventListener("pointerleave", () => { tip.hidden = true; view.setHover(null); });
  canvas.addEventListener("keydown", (e) => { if (e.key === " ") { e.preventDefault(); setPlaying(!view.playing); } });

  replace(host, h("div", { class: "viewer" }, stage,
    h("div", { class: "side" },
      h("fieldset", {}, h("legend", {}, "Model"), h("label", { for: "viewer-model" }, "File"), modelSelect, toggle,
        h("details", {}, h("summary", {}, "Open another GLB"), urlForm, h("label", {}, "or a local file ", fileInput))),
      h("fieldset", {}, h("legend", {}, "Colour"),
        ...modeRadios.map((r) => h("label", {}, r, " ", modeLabels[r.value as ColorMode])),
        h("label", { for: "viewer-bone" }, "Bone"), boneSelect, legend,
        h("label", {}, skeletonBox, " Skeleton overlay")),
      pose.el,
      editor?.el ?? null,
      h("fieldset", {}, h("legend", {}, "Animation"), h("label", { for: "viewer-clip" }, "Clip"), clipSelect,
        h("div", { class: "row" }, playButton, timeText), scrub,
        h("label", { title: "keep the character in view when the clip moves it" }, followBox, " Follow the character")),
      worst.length ? h("fieldset", { id: "viewer-worst" }, h("legend", {}, "Worst frames (quality checks)"), ...worstButtons) : null)),
  plot ? h("div", { class: "panel", style: "margin-top:12px" }, h("h3", {}, "Volume change: LBS vs physics"),
    h("p", { class: "muted" }, "signed volume relative to the rest pose per frame; physics should stay nearer 0 %"), plot.el) : null);

  showSelection();
  return () => { disposed = true; editor?.dispose(); view.dispose(); delete window.rigforgeViewer; };
}
