// Skeleton editing on a finished job: pick a joint (click its sphere or the list), move it (transform gizmo or
// numbers), add, delete, re-parent and rename joints of the job's skeleton.json, then "Re-skin" submits a new job
// with the edited skeleton (skeleton: keep, the job's mesh.glb, source_job linking the two, the job's other options
// and its baked clip) and opens it. Positions are in the ingested mesh's frame (metres, +Y up), which is the frame of
// the rigged model's root: the edit overlay hangs under it.
import * as THREE from "three";
import { TransformControls } from "three/examples/jsm/controls/TransformControls.js";
import { ApiError, api, toProblem, type Artifact, type JobOptions, type JobOptionsInput } from "../api/client";
import { getKey } from "../api/session";
import { h, replace } from "../ui/dom";
import type { SceneView } from "./scene_view";

type Vec3 = [number, number, number];

/** The part of skeleton.json that is edited; the rest (tokens, skin order) no longer applies. A kept studio
 *  rig's bind frames (`orientations`, xyzw) stay with their joints, so its own clips still fit the edited rig, and
 *  so do the joints' `kinds` (a root at the file's origin is a helper that takes no weight). */
export interface EditableSkeleton {
  names: string[]; parents: number[]; positions: Vec3[]; orientations?: number[][] | null; kinds?: string[] | null;
}

const JOINT = new THREE.Color("#7fd1ff"), SELECTED = new THREE.Color("#ff3b6b");

/** Remove joint `j` (not the root): its children hang from its parent; indices above it shift down. */
export function deleteJoint(s: EditableSkeleton, j: number): EditableSkeleton {
  const parent = s.parents[j];
  const keep = s.names.map((_, i) => i).filter((i) => i !== j);
  const index = new Map(keep.map((i, k) => [i, k]));
  return {
    names: keep.map((i) => s.names[i]),
    parents: keep.map((i) => { const p = s.parents[i] === j ? parent : s.parents[i]; return p < 0 ? -1 : index.get(p)!; }),
    positions: keep.map((i) => [...s.positions[i]] as Vec3),
    orientations: s.orientations ? keep.map((i) => [...s.orientations![i]]) : null,
    kinds: s.kinds ? keep.map((i) => s.kinds![i]) : null,
  };
}

/** The re-skin job's options: the source job's skinning, refinement and export choices, on the edited skeleton as it
 *  is (skeleton: keep; mesh.glb is metres, +Y up already; names as edited, so no naming preset). With the source's
 *  animated.glb as motion (its clip already cut, resampled and put in place) only `loop` still applies, and joints
 *  renamed in the editor are mapped from their old names, which the clip uses. */
export function reskinOptions(source: JobOptions, renamed: Record<string, string>, withClip: boolean): JobOptionsInput {
  return {
    skeleton: "keep", units: "m", skinning: source.skinning, max_influences: source.max_influences,
    smooth_iterations: source.smooth_iterations, exclude_joints: source.exclude_joints, refine: source.refine,
    fbx: source.fbx, quality_gate: source.quality_gate,
    motion: withClip ? { loop: source.motion?.loop ?? false, joint_map: renamed } : undefined,
  };
}

/** Joints that may become `j`'s parent: any joint but itself and its descendants (no cycles). */
export function parentChoices(s: EditableSkeleton, j: number): number[] {
  const below = new Set([j]);
  for (let grew = true; grew;) {
    grew = false;
    s.parents.forEach((p, i) => { if (p >= 0 && below.has(p) && !below.has(i)) { below.add(i); grew = true; } });
  }
  return s.names.map((_, i) => i).filter((i) => !below.has(i));
}

export interface RigEditor { el: HTMLElement; close: () => void; dispose: () => void }

export function rigEditor(view: SceneView, jobId: string, artifacts: Artifact[]): RigEditor | null {
  const skeletonArt = artifacts.find((a) => a.name === "skeleton.json");
  const meshArt = artifacts.find((a) => a.name === "mesh.glb");
  const clipArt = artifacts.find((a) => a.name === "animated.glb");
  if (!skeletonArt || !meshArt) return null;
  let skel: EditableSkeleton | null = null;
  let origins: (string | null)[] = [];  // each joint's name in the job's skeleton.json (null: added here)
  let selected = 0;
  let group: THREE.Group | null = null;
  let gizmo: TransformControls | null = null;
  const spheres: THREE.Mesh[] = [];
  const ray = new THREE.Raycaster();
  let pressed: { x: number; y: number } | null = null;
  const lines = new THREE.LineSegments(new THREE.BufferGeometry(), new THREE.LineBasicMaterial({ color: "#bfe8ff", depthTest: false, transparent: true }));
  lines.renderOrder = 1000;

  const status = h("p", { class: "muted", id: "edit-status", "aria-live": "polite" }, "edit the skeleton, then re-skin it as a new job");
  const jointSelect = h("select", { id: "edit-joint", onchange: () => select(Number(jointSelect.value)) });
  const nameInput = h("input", { id: "edit-name", maxlength: "200", onchange: () => rename(nameInput.value.trim()) }) as HTMLInputElement;
  const parentSelect = h("select", { id: "edit-parent", onchange: () => reparent(Number(parentSelect.value)) });
  const coords = (["x", "y", "z"] as const).map((axis, i) => h("input", { type: "number", step: "0.001", id: `edit-${axis}`,
    "aria-label": `${axis} (metres)`, onchange: () => moveTo(i, Number(coords[i].value)) }) as HTMLInputElement);
  const addButton = h("button", { type: "button", id: "edit-add", onclick: () => addChild() }, "Add child joint");
  const deleteButton = h("button", { type: "button", id: "edit-delete", class: "danger", onclick: () => remove() }, "Delete joint");
  const reskinButton = h("button", { type: "button", id: "edit-reskin", onclick: () => reskin() }, "Re-skin as a new job");
  const body = h("div", { hidden: true }, h("label", { for: "edit-joint" }, "Joint"), jointSelect,
    h("label", { for: "edit-name" }, "Name"), nameInput, h("label", { for: "edit-parent" }, "Parent"), parentSelect,
    h("div", { class: "row" }, ...coords), h("div", { class: "row" }, addButton, deleteButton), reskinButton, status);
  const openButton = h("button", { type: "button", id: "edit-open", onclick: () => (skel ? close() : open()) }, "Edit skeleton");
  const el = h("fieldset", { id: "viewer-edit" }, h("legend", {}, "Edit skeleton"), openButton, body);

  async function open(): Promise<void> {
    const doc = (await api.artifactJson(skeletonArt!.url)) as EditableSkeleton;
    skel = { names: [...doc.names], parents: [...doc.parents], positions: doc.positions.map((p) => [...p] as Vec3),
      orientations: doc.orientations ? doc.orientations.map((q) => [...q]) : null, kinds: doc.kinds ? [...doc.kinds] : null };
    origins = [...doc.names];
    const model = view.models[0];
    if (!model) return;
    view.setClip(null);  // the bind pose the joints belong to
    view.setSkeletonVisible(false);
    group = new THREE.Group();
    group.add(lines);
    model.root.add(group);
    gizmo = new TransformControls(view.camera, view.canvas);
    gizmo.setSpace("world");
    gizmo.addEventListener("dragging-changed", (e) => { view.controls.enabled = !(e as unknown as { value: boolean }).value; });
    gizmo.addEventListener("objectChange", () => {
      const p = spheres[selected].position;
      setPosition([p.x, p.y, p.z]);
    });
    gizmo.addEventListener("change", () => view.invalidate());
    view.scene.add(gizmo.getHelper());
    view.canvas.addEventListener("pointerdown", onPointerDown);
    view.canvas.addEventListener("pointerup", onPointerUp);
    openButton.textContent = "Stop editing";
    body.hidden = false;
    rebuild();
    select(0);
  }

  function close(): void {
    if (!skel) return;
    disposeScene();
    skel = null;
    body.hidden = true;
    openButton.textContent = "Edit skeleton";
    view.setSkeletonVisible(true);
  }

  // A click (not a drag, not on the gizmo's handles) on a joint's sphere picks that joint.
  function onPointerDown(e: PointerEvent): void { pressed = gizmo?.axis ? null : { x: e.offsetX, y: e.offsetY }; }
  function onPointerUp(e: PointerEvent): void {
    if (!skel || !pressed || Math.hypot(e.offsetX - pressed.x, e.offsetY - pressed.y) > 4) return;
    const j = pickSphere(e.offsetX, e.offsetY);
    if (j >= 0) select(j);
  }

  /** The joint whose sphere is nearest the camera under canvas point (x, y) in CSS px, else -1. */
  function pickSphere(x: number, y: number): number {
    const c = view.canvas;
    ray.setFromCamera(new THREE.Vector2((x / c.clientWidth) * 2 - 1, -(y / c.clientHeight) * 2 + 1), view.camera);
    const hit = ray.intersectObjects(spheres, false)[0];
    return hit ? spheres.indexOf(hit.object as THREE.Mesh) : -1;
  }

  function rebuild(): void {
    if (!skel || !group) return;
    for (const s of spheres.splice(0)) { group.remove(s); s.geometry.dispose(); (s.material as THREE.Material).dispose(); }
    const size = new THREE.Box3().setFromObject(view.models[0].root).getSize(new THREE.Vector3()).length();
    skel.positions.forEach((p, i) => {
      const sphere = new THREE.Mesh(new THREE.SphereGeometry(size * 0.012, 12, 8),
        new THREE.MeshBasicMaterial({ color: i === selected ? SELECTED : JOINT, depthTest: false, transparent: true }));
      sphere.position.set(...p);
      sphere.renderOrder = 1001;
      group!.add(sphere);
      spheres.push(sphere);
    });
    replace(jointSelect, ...skel.names.map((n, i) => h("option", { value: String(i) }, n)));
    drawBones();
  }

  function drawBones(): void {
    if (!skel) return;
    const pts = skel.parents.flatMap((p, i) => (p < 0 ? [] : [...skel!.positions[i], ...skel!.positions[p]]));
    lines.geometry.setAttribute("position", new THREE.Float32BufferAttribute(pts, 3));
    view.invalidate();
  }

  function select(j: number): void {
    if (!skel) return;
    selected = j;
    spheres.forEach((s, i) => (s.material as THREE.MeshBasicMaterial).color.copy(i === j ? SELECTED : JOINT));
    gizmo?.attach(spheres[j]);
    jointSelect.value = String(j);
    nameInput.value = skel.names[j];
    const root = skel.parents[j] < 0;
    replace(parentSelect, ...(root ? [h("option", { value: "-1" }, "— root —")] :
      parentChoices(skel, j).map((i) => h("option", { value: String(i) }, skel!.names[i]))));
    parentSelect.value = String(skel.parents[j]);
    parentSelect.disabled = deleteButton.disabled = root;
    coords.forEach((c, i) => { c.value = skel!.positions[j][i].toFixed(4); });
    view.invalidate();
  }

  function setPosition(p: Vec3): void {
    if (!skel) return;
    skel.positions[selected] = p;
    spheres[selected].position.set(...p);
    coords.forEach((c, i) => { c.value = p[i].toFixed(4); });
    drawBones();
  }

  function moveTo(axis: number, value: number): void {
    if (!skel || !Number.isFinite(value)) return;
    const p = [...skel.positions[selected]] as Vec3;
    p[axis] = value;
    setPosition(p);
  }

  function rename(name: string): void {
    if (!skel) return;
    if (!name || skel.names.some((n, i) => n === name && i !== selected)) {
      status.textContent = `"${name}" is empty or taken: joint names must be unique`;
      nameInput.value = skel.names[selected];
      return;
    }
    skel.names[selected] = name;
    jointSelect.options[selected].textContent = name;
  }

  function reparent(parent: number): void {
    if (!skel || skel.parents[selected] < 0) return;
    skel.parents[selected] = parent;
    drawBones();
  }

  function addChild(): void {
    if (!skel) return;
    const p = skel.positions[selected], q = skel.parents[selected] >= 0 ? skel.positions[skel.parents[selected]] : null;
    const step = q ? p.map((v, i) => 0.5 * (v - q[i])) : [0, 0.05, 0];
    let k = 1;
    while (skel.names.includes(`joint_new_${k}`)) k++;
    skel.names.push(`joint_new_${k}`);
    skel.parents.push(selected);
    skel.positions.push(p.map((v, i) => v + step[i]) as Vec3);
    skel.orientations?.push([...skel.orientations[selected]]);  // a new joint starts in its parent's frame
    skel.kinds?.push("free");
    origins.push(null);
    rebuild();
    select(skel.names.length - 1);
  }

  function remove(): void {
    if (!skel || skel.parents[selected] < 0) return;
    const parent = skel.parents[selected];
    skel = deleteJoint(skel, selected);
    origins = origins.filter((_, i) => i !== selected);
    rebuild();
    select(parent < selected ? parent : parent - 1);
  }

  async function reskin(): Promise<void> {
    if (!skel) return;
    reskinButton.disabled = true;
    status.textContent = "submitting…";
    try {
      const edited = skel;
      const renamed = Object.fromEntries(origins.flatMap((o, i) => (o !== null && o !== edited.names[i] ? [[o, edited.names[i]]] : [])));
      const form = new FormData();
      form.append("mesh", new Blob([await api.artifactBytes(meshArt!.url)]), "mesh.glb");
      form.append("skeleton", new Blob([JSON.stringify(skel)], { type: "application/json" }), "edited-skeleton.json");
      if (clipArt) form.append("motion", new Blob([await api.artifactBytes(clipArt.url)]), "animated.glb");
      const source = (await api.getJob(jobId)).options as JobOptions;  // the job as stored: every option filled in
      form.append("options", JSON.stringify(reskinOptions(source, renamed, !!clipArt)));
      form.append("source_job", jobId);
      const key = getKey();
      const res = await fetch("/api/v1/jobs", { method: "POST", body: form, headers: key ? { Authorization: `Bearer ${key}` } : {} });
      const text = await res.text();
      if (res.status !== 202) throw new ApiError(toProblem(res.status, text));
      location.hash = `#/jobs/${(JSON.parse(text) as { id: string }).id}`;
    } catch (e) {
      status.textContent = `could not re-skin: ${e instanceof Error ? e.message : e}`;
      reskinButton.disabled = false;
    }
  }

  function disposeScene(): void {
    view.canvas.removeEventListener("pointerdown", onPointerDown);
    view.canvas.removeEventListener("pointerup", onPointerUp);
    if (gizmo) { gizmo.detach(); view.scene.remove(gizmo.getHelper()); gizmo.dispose(); gizmo = null; }
    if (group) { group.parent?.remove(group); group = null; }
    for (const s of spheres.splice(0)) { s.geometry.dispose(); (s.material as THREE.Material).dispose(); }
    view.controls.enabled = true;
    view.invalidate();
  }

  return { el, close, dispose: () => { disposeScene(); lines.geometry.dispose(); (lines.material as THREE.Material).dispose(); } };
}
