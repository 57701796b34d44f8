// Per-vertex colours from a SkinnedMesh's skin attributes: one bone's weight as a heat map, or the dominant bone.
import * as THREE from "three";

// Blender-like weight ramp, 0 → dark blue, 1 → red (the CSS legend uses the same stops).
const RAMP = ["#00008f", "#0050ff", "#00d5ff", "#3cff8a", "#f0ff00", "#ff8c00", "#c80000"].map((c) => new THREE.Color(c));

export function rampColor(t: number, out: THREE.Color): THREE.Color {
  const x = Math.min(Math.max(t, 0), 1) * (RAMP.length - 1);
  const i = Math.min(Math.floor(x), RAMP.length - 2);
  return out.copy(RAMP[i]).lerp(RAMP[i + 1], x - i);
}

/** A distinct colour for bone `index` (golden-angle hues). */
export function boneColor(index: number, out = new THREE.Color()): THREE.Color {
  return out.setHSL((index * 0.618034) % 1, 0.7, 0.55);
}

/** Influence sets of a geometry: JOINTS_0/WEIGHTS_0 and, for 8 influences, JOINTS_1/WEIGHTS_1. */
function influenceSets(geometry: THREE.BufferGeometry): [THREE.BufferAttribute, THREE.BufferAttribute][] {
  const sets: [THREE.BufferAttribute, THREE.BufferAttribute][] = [];
  for (const [j, w] of [["skinIndex", "skinWeight"], ["joints_1", "weights_1"]]) {
    const ja = geometry.getAttribute(j), wa = geometry.getAttribute(w);
    if (ja && wa) sets.push([ja as THREE.BufferAttribute, wa as THREE.BufferAttribute]);
  }
  return sets;
}

/** weights: (V,) float32 weight of skeleton bone `boneIndex` at every vertex. */
export function boneWeights(geometry: THREE.BufferGeometry, boneIndex: number): Float32Array {
  const count = geometry.getAttribute("position").count;
  const out = new Float32Array(count);
  for (const [joints, weights] of influenceSets(geometry)) {
    for (let v = 0; v < count; v++) {
      for (let k = 0; k < joints.itemSize; k++) {
        if (joints.getComponent(v, k) === boneIndex) out[v] += weights.getComponent(v, k);
      }
    }
  }
  return out;
}

/** colors: (V*3,) float32 heat map of one bone's weights. */
export function heatColors(geometry: THREE.BufferGeometry, boneIndex: number): Float32Array {
  const w = boneWeights(geometry, boneIndex);
  const colors = new Float32Array(w.length * 3);
  const c = new THREE.Color();
  for (let v = 0; v < w.length; v++) rampColor(w[v], c).toArray(colors, v * 3);
  return colors;
}

/** colors: (V*3,) float32, each vertex the weight-blended colour of the bones that move it. */
export function dominantColors(geometry: THREE.BufferGeometry, boneIndexToColor: (i: number) => THREE.Color): Float32Array {
  const count = geometry.getAttribute("position").count;
  const colors = new Float32Array(count * 3);
  for (const [joints, weights] of influenceSets(geometry)) {
    for (let v = 0; v < count; v++) {
      for (let k = 0; k < joints.itemSize; k++) {
        const w = weights.getComponent(v, k);
        if (w <= 0) continue;
        const c = boneIndexToColor(joints.getComponent(v, k));
        colors[v * 3] += w * c.r; colors[v * 3 + 1] += w * c.g; colors[v * 3 + 2] += w * c.b;
      }
    }
  }
  return colors;
}

/** The bone with the largest summed weight over `vertices` (e.g. the corners of a clicked triangle); -1 if none. */
export function dominantBone(geometry: THREE.BufferGeometry, vertices: number[]): number {
  const totals = new Map<number, number>();
  for (const [joints, weights] of influenceSets(geometry)) {
    for (const v of vertices) {
      for (let k = 0; k < joints.itemSize; k++) {
        const w = weights.getComponent(v, k);
        if (w > 0) totals.set(joints.getComponent(v, k), (totals.get(joints.getComponent(v, k)) ?? 0) + w);
      }
    }
  }
  let best = -1, bestW = 0;
  for (const [b, w] of totals) if (w > bestW) { best = b; bestW = w; }
  return best;
}
