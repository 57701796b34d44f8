// Joints (spheres) and bones (lines) of a skeleton, drawn on top of the mesh and following the animation.
import * as THREE from "three";

const JOINT = new THREE.Color("#ffd24a"), SELECTED = new THREE.Color("#ff3b6b"), HOVER = new THREE.Color("#ffffff");

export class SkeletonOverlay {
  readonly group = new THREE.Group();
  private readonly joints: THREE.InstancedMesh;
  private readonly lines: THREE.LineSegments;
  private readonly pairs: [number, number][] = [];  // (child, parent) indices into bones
  private readonly tmp = new THREE.Vector3();
  private readonly matrix = new THREE.Matrix4();
  selected = -1;
  hovered = -1;

  /** bones: the skeleton's joints; radius: joint sphere radius in metres. */
  constructor(readonly bones: THREE.Bone[], radius: number) {
    const index = new Map(bones.map((b, i) => [b, i]));
    bones.forEach((b, i) => { const p = index.get(b.parent as THREE.Bone); if (p !== undefined) this.pairs.push([i, p]); });
    const onTop = { depthTest: false, depthWrite: false, transparent: true };
    this.joints = new THREE.InstancedMesh(new THREE.SphereGeometry(radius, 12, 8), new THREE.MeshBasicMaterial({ ...onTop, opacity: 0.95 }), bones.length);
    this.lines = new THREE.LineSegments(new THREE.BufferGeometry(), new THREE.LineBasicMaterial({ ...onTop, color: "#ffe9a8", opacity: 0.9 }));
    this.lines.geometry.setAttribute("position", new THREE.BufferAttribute(new Float32Array(this.pairs.length * 6), 3));
    this.joints.frustumCulled = this.lines.frustumCulled = false;  // positions change every frame
    this.joints.renderOrder = 1001;
    this.lines.renderOrder = 1000;
    this.group.add(this.lines, this.joints);
    this.update();
  }

  /** Follow the bones' current world positions and the selection colours. */
  update(): void {
    const pos = this.lines.geometry.getAttribute("position") as THREE.BufferAttribute;
    this.bones.forEach((b, i) => {
      b.getWorldPosition(this.tmp);
      this.joints.setMatrixAt(i, this.matrix.makeTranslation(this.tmp.x, this.tmp.y, this.tmp.z));
      this.joints.setColorAt(i, i === this.selected ? SELECTED : i === this.hovered ? HOVER : JOINT);
    });
    this.pairs.forEach(([c, p], k) => {
      this.bones[c].getWorldPosition(this.tmp); pos.setXYZ(2 * k, this.tmp.x, this.tmp.y, this.tmp.z);
      this.bones[p].getWorldPosition(this.tmp); pos.setXYZ(2 * k + 1, this.tmp.x, this.tmp.y, this.tmp.z);
    });
    pos.needsUpdate = true;
    this.joints.instanceMatrix.needsUpdate = true;
    if (this.joints.instanceColor) this.joints.instanceColor.needsUpdate = true;
  }

  /** Joint positions in CSS pixels relative to the canvas: (J,) {x, y, visible}. */
  screenPoints(camera: THREE.Camera, width: number, height: number): { x: number; y: number; inFront: boolean }[] {
    return this.bones.map((b) => {
      const p = b.getWorldPosition(this.tmp).project(camera);
      return { x: (p.x + 1) * 0.5 * width, y: (1 - p.y) * 0.5 * height, inFront: p.z > -1 && p.z < 1 };
    });
  }

  dispose(): void {
    this.joints.geometry.dispose();
    (this.joints.material as THREE.Material).dispose();
    this.lines.geometry.dispose();
    (this.lines.material as THREE.Material).dispose();
  }
}
