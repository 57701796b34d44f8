// The three.js viewer: loads GLBs, orbits, colours by bone weights, overlays the skeleton, plays animations.
// Several models can be shown side by side (LBS vs physics-refined) and share one clock.
import * as THREE from "three";
import { OrbitControls } from "three/examples/jsm/controls/OrbitControls.js";
import { GLTFLoader } from "three/examples/jsm/loaders/GLTFLoader.js";
import { SkeletonOverlay } from "./skeleton_overlay";
import { boneColor, dominantBone, dominantColors, heatColors } from "./weight_colors";

export type ColorMode = "texture" | "weights" | "dominant";

export interface LoadedModel {
  label: string;
  root: THREE.Object3D;
  clips: THREE.AnimationClip[];
  mixer: THREE.AnimationMixer;
  skinned: THREE.SkinnedMesh[];
  meshes: THREE.Mesh[];
  bones: THREE.Bone[];  // unique bones of every skin, in skeleton order
  overlay: SkeletonOverlay | null;
  action: THREE.AnimationAction | null;
  vertices: number;
}

type Original = { material: THREE.Material | THREE.Material[]; color: THREE.BufferAttribute | THREE.InterleavedBufferAttribute | undefined };

export class SceneView {
  readonly renderer: THREE.WebGLRenderer;
  readonly camera = new THREE.PerspectiveCamera(40, 1, 0.01, 1000);
  readonly scene = new THREE.Scene();
  readonly controls: OrbitControls;
  models: LoadedModel[] = [];
  colorMode: ColorMode = "texture";
  selectedBone: string | null = null;
  showSkeleton = true;
  follow = true;  // the camera tracks the first model's root bone horizontally (clips that walk away stay in view)
  playing = false;
  time = 0;
  onTime: (t: number) => void = () => {};
  private readonly originals = new Map<THREE.Mesh, Original>();
  private readonly vertexMaterial = new THREE.MeshLambertMaterial({ vertexColors: true, side: THREE.DoubleSide });
  private readonly clock = new THREE.Clock();
  private readonly grid: THREE.GridHelper;
  private dirty = true;
  private frame = 0;
  private clipName: string | null = null;
  private followAnchor: THREE.Vector3 | null = null;  // root bone position the camera was last placed for
  private resize: ResizeObserver;
  private readonly poseRest = new Map<THREE.Bone, THREE.Quaternion>();  // bones the pose test turned: their rotation before

  constructor(readonly canvas: HTMLCanvasElement) {
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
    this.renderer.outputColorSpace = THREE.SRGBColorSpace;
    this.scene.background = new THREE.Color("#2a2f3a");
    this.scene.add(new THREE.HemisphereLight("#ffffff", "#444a55", 2.2));
    const sun = new THREE.DirectionalLight("#ffffff", 2.0);
    sun.position.set(3, 6, 4);
    this.scene.add(sun);
    this.grid = new THREE.GridHelper(4, 20, "#59606e", "#3a404c");
    this.scene.add(this.grid);
    this.controls = new OrbitControls(this.camera, canvas);
    this.controls.enableDamping = false;  // render on demand: no coasting frames
    this.controls.addEventListener("change", () => this.invalidate());
    this.controls.listenToKeyEvents(canvas);  // arrow keys pan when the canvas has focus
    this.resize = new ResizeObserver(() => this.fit());
    this.resize.observe(canvas.parentElement!);
    this.fit();
    this.loop();
  }

  invalidate(): void {
    this.dirty = true;
  }

  private fit(): void {
    const el = this.canvas.parentElement!;
    const w = el.clientWidth, h = el.clientHeight;
    if (!w || !h) return;
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.invalidate();
  }

  private loop = (): void => {
    this.frame = requestAnimationFrame(this.loop);
    const dt = this.clock.getDelta();
    if (this.playing && this.duration() > 0) {
      this.setTime((this.time + dt) % this.duration());
      this.onTime(this.time);
    }
    if (!this.dirty) return;
    this.dirty = false;
    for (const m of this.models) m.overlay?.update();
    this.renderer.render(this.scene, this.camera);
  };

  /** Parse GLB bytes into a model (not yet shown). */
  async load(bytes: ArrayBuffer, label: string): Promise<LoadedModel> {
    const gltf = await new GLTFLoader().parseAsync(bytes, "");
    const root = gltf.scene;
    const skinned: THREE.SkinnedMesh[] = [], meshes: THREE.Mesh[] = [];
    let vertices = 0;
    root.traverse((o) => {
      if ((o as THREE.SkinnedMesh).isSkinnedMesh) skinned.push(o as THREE.SkinnedMesh);
      if ((o as THREE.Mesh).isMesh) { meshes.push(o as THREE.Mesh); vertices += (o as THREE.Mesh).geometry.getAttribute("position").count; }
    });
    const bones = [...new Set(skinned.flatMap((s) => s.skeleton.bones))];
    return { label, root, clips: gltf.animations, mixer: new THREE.AnimationMixer(root), skinned, meshes, bones, overlay: null, action: null, vertices };
  }

  /** Show `models` (side by side when several), frame the camera on them, keep the colour mode and clip. */
  show(models: LoadedModel[]): void {
    this.resetPose();
    for (const m of this.models) { this.scene.remove(m.root); if (m.overlay) { this.scene.remove(m.overlay.group); m.overlay.dispose(); } }
    this.models = models;
    // View the creature from the side of its long horizontal axis (a profile for quadrupeds, the front for
    // humanoids), slightly from above and turned; several models line up along that axis, left to right on screen.
    const boxes = models.map((m) => { m.root.position.set(0, 0, 0); m.root.updateMatrixWorld(true); return new THREE.Box3().setFromObject(m.root); });
    const first = boxes[0].getSize(new THREE.Vector3());
    const along: "x" | "z" = first.x >= first.z ? "x" : "z";
    const yaw = models.length > 1 ? 0.1 : 0.3;  // nearly square-on when comparing, so both models show at one scale
    const viewDir = along === "x" ? new THREE.Vector3(yaw, 0.4, 1) : new THREE.Vector3(1, 0.4, -yaw);
    viewDir.normalize();
    const right = viewDir.clone().negate().cross(new THREE.Vector3(0, 1, 0));
    const sign = Math.sign(right[along]) || 1;
    const extent = (b: THREE.Box3) => b.max[along] - b.min[along];
    const gap = 0.2 * Math.max(...boxes.map(extent));
    let cursor = 0;
    models.forEach((m, i) => {
      m.root.position[along] = sign * (cursor + extent(boxes[i]) / 2) - (boxes[i].min[along] + boxes[i].max[along]) / 2;
      cursor += extent(boxes[i]) + gap;
    });
    const box = new THREE.Box3();
    for (const m of models) {
      m.root.position[along] -= sign * (cursor - gap) / 2;
      this.scene.add(m.root);
      m.root.updateMatrixWorld(true);
      box.union(new THREE.Box3().setFromObject(m.root));
    }
    const size = box.getSize(new THREE.Vector3()), center = box.getCenter(new THREE.Vector3());
    const radius = Math.max(first.length() / 2, 1e-3);
    for (const m of models) {
      if (m.bones.length) {
        m.overlay = new SkeletonOverlay(m.bones, radius * 0.018);
        this.scene.add(m.overlay.group);
      }
    }
    this.grid.scale.setScalar(Math.max(size.x, size.z, 0.5) * 0.6);
    this.grid.position.set(center.x, box.min.y, center.z);
    // Fit the box (not its bounding sphere, which is loose for long creatures) in both screen directions.
    const half = Math.tan(THREE.MathUtils.degToRad(this.camera.fov / 2));
    const width = size[along], depth = along === "x" ? size.z : size.x;
    const dist = 1.2 * Math.max(size.y / 2 / half, width / 2 / (half * this.camera.aspect)) + depth / 2;
    this.camera.near = dist / 100; this.camera.far = dist * 100;
    this.camera.position.copy(center).add(viewDir.multiplyScalar(dist));
    this.camera.updateProjectionMatrix();
    this.controls.target.copy(center);
    this.controls.update();
    this.followAnchor = this.rootPosition();  // framed on the bind pose; the clip's first frame moves the camera
    this.setClip(this.clipName && this.clipNames().includes(this.clipName) ? this.clipName : this.clipNames()[0] ?? null);
    this.applyColors();
    this.setSkeletonVisible(this.showSkeleton);
  }

  clipNames(): string[] {
    return [...new Set(this.models.flatMap((m) => m.clips.map((c) => c.name)))];
  }

  boneNames(): string[] {
    return [...new Set(this.models.flatMap((m) => m.bones.map((b) => b.name)))];
  }

  duration(): number {
    return Math.max(0, ...this.models.flatMap((m) => m.clips.filter((c) => c.name === this.clipName).map((c) => c.duration)));
  }

  /** Turn bone `name` of every model by (x, y, z) degrees (XYZ Euler, in its own frame) from where it was before
   *  the pose test first turned it, to see how its weights deform the mesh. */
  poseBone(name: string, degrees: [number, number, number]): void {
    const turn = new THREE.Quaternion().setFromEuler(new THREE.Euler(...degrees.map((d) => THREE.MathUtils.degToRad(d)) as [number, number, number]));
    for (const m of this.models) {
      const bone = m.bones.find((b) => b.name === name);
      if (!bone) continue;
      if (!this.poseRest.has(bone)) this.poseRest.set(bone, bone.quaternion.clone());
      bone.quaternion.copy(this.poseRest.get(bone)!).multiply(turn);
    }
    this.invalidate();
  }

  /** Put every bone the pose test turned back where it was. */
  resetPose(): void {
    for (const [bone, rest] of this.poseRest) bone.quaternion.copy(rest);
    this.poseRest.clear();
    this.invalidate();
  }

  /** Play `name` on every model that has it (the bind pose when null). */
  setClip(name: string | null): void {
    this.resetPose();
    this.clipName = name;
    for (const m of this.models) {
      m.mixer.stopAllAction();
      const clip = m.clips.find((c) => c.name === name);
      m.action = clip ? m.mixer.clipAction(clip).play() : null;
      if (clip) continue;
      m.root.traverse((o) => { if ((o as THREE.SkinnedMesh).isSkinnedMesh) (o as THREE.SkinnedMesh).skeleton.pose(); });
    }
    this.setTime(0);
  }

  setTime(t: number): void {
    this.time = t;
    for (const m of this.models) {
      if (m.action) m.action.time = Math.min(t, m.action.getClip().duration);
      m.mixer.update(0);
    }
    this.followRoot();
    this.invalidate();
  }

  private rootPosition(): THREE.Vector3 | null {
    const bone = this.models[0]?.bones[0];
    if (!bone) return null;
    bone.updateWorldMatrix(true, false);
    return bone.getWorldPosition(new THREE.Vector3());
  }

  /** Move camera and orbit target by the root bone's horizontal displacement since the last call. */
  private followRoot(): void {
    const now = this.rootPosition();
    if (now && this.followAnchor && this.follow) {
      const delta = now.clone().sub(this.followAnchor).setY(0);
      this.camera.position.add(delta);
      this.controls.target.add(delta);
      this.controls.update();
    }
    this.followAnchor = now;
  }

  setSkeletonVisible(on: boolean): void {
    this.showSkeleton = on;
    for (const m of this.models) if (m.overlay) m.overlay.group.visible = on;
    this.invalidate();
  }

  selectBone(name: string | null): void {
    this.selectedBone = name;
    for (const m of this.models) if (m.overlay) m.overlay.selected = name === null ? -1 : m.bones.findIndex((b) => b.name === name);
    this.applyColors();
  }

  setColorMode(mode: ColorMode): void {
    this.colorMode = mode;
    this.applyColors();
  }

  /** Textured materials, or vertex colours from the skin (heat map of the selected bone / dominant bone). */
  private applyColors(): void {
    const names = this.boneNames();
    for (const m of this.models) {
      for (const mesh of m.meshes) {
        const skinned = (mesh as THREE.SkinnedMesh).isSkinnedMesh ? (mesh as THREE.SkinnedMesh) : null;
        if (this.colorMode === "texture" || !skinned) { this.restore(mesh); continue; }
        if (!this.originals.has(mesh)) this.originals.set(mesh, { material: mesh.material, color: mesh.geometry.getAttribute("color") });
        const bones = skinned.skeleton.bones;
        // Colours follow bone names, so LBS and physics models side by side agree.
        const palette = bones.map((b) => boneColor(Math.max(names.indexOf(b.name), 0)));
        const colors = this.colorMode === "weights"
          ? heatColors(mesh.geometry, bones.findIndex((b) => b.name === this.selectedBone))
          : dominantColors(mesh.geometry, (i) => palette[i] ?? palette[0]);
        mesh.geometry.setAttribute("color", new THREE.BufferAttribute(colors, 3));
        mesh.material = this.vertexMaterial;
      }
    }
    this.invalidate();
  }

  private restore(mesh: THREE.Mesh): void {
    const o = this.originals.get(mesh);
    if (!o) return;
    mesh.material = o.material;
    if (o.color) mesh.geometry.setAttribute("color", o.color); else mesh.geometry.deleteAttribute("color");
    this.originals.delete(mesh);
  }

  /** Joints on screen (CSS px relative to the canvas), for picking, hover names and tests. */
  jointScreenPoints(): { model: number; bone: number; name: string; x: number; y: number }[] {
    const w = this.canvas.clientWidth, h = this.canvas.clientHeight;
    this.camera.updateMatrixWorld();
    return this.models.flatMap((m, mi) => !m.overlay || !m.overlay.group.visible ? [] :
      m.overlay.screenPoints(this.camera, w, h).map((p, bi) => ({ model: mi, bone: bi, name: m.bones[bi].name, ...p }))
        .filter((p) => p.inFront && p.x >= 0 && p.y >= 0 && p.x <= w && p.y <= h).map(({ inFront: _, ...p }) => p));
  }

  /** The joint within `radius` px of (x, y) on the canvas, else null. */
  pickJoint(x: number, y: number, radius = 12): { model: number; bone: number; name: string } | null {
    let best = null, bestD = radius * radius;
    for (const p of this.jointScreenPoints()) {
      const d = (p.x - x) ** 2 + (p.y - y) ** 2;
      if (d <= bestD) { best = p; bestD = d; }
    }
    return best;
  }

  /** The bone that most moves the triangle under (x, y) on the canvas, else null. */
  pickSurfaceBone(x: number, y: number): string | null {
    const ray = new THREE.Raycaster();
    ray.setFromCamera(new THREE.Vector2((x / this.canvas.clientWidth) * 2 - 1, -(y / this.canvas.clientHeight) * 2 + 1), this.camera);
    const hit = ray.intersectObjects(this.models.flatMap((m) => m.skinned), false)[0];
    if (!hit?.face) return null;
    const mesh = hit.object as THREE.SkinnedMesh;
    const bone = dominantBone(mesh.geometry, [hit.face.a, hit.face.b, hit.face.c]);
    return bone >= 0 ? mesh.skeleton.bones[bone]?.name ?? null : null;
  }

  setHover(name: string | null): void {
    for (const m of this.models) if (m.overlay) m.overlay.hovered = name === null ? -1 : m.bones.findIndex((b) => b.name === name);
    this.invalidate();
  }

  dispose(): void {
    cancelAnimationFrame(this.frame);
    this.resize.disconnect();
    this.controls.dispose();
    this.renderer.dispose();
    this.renderer.forceContextLoss();  // browsers cap live WebGL contexts; free ours when the page closes
  }
}
