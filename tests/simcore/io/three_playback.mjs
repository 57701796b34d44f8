// Load a GLB with three.js GLTFLoader in Node, play its first clip with AnimationMixer, print JSON:
// node three_playback.mjs FILE TIME... → {animations, skinned, bones, morphTargets, frames: [[5 world vertex positions] per TIME]}
import { readFileSync } from "node:fs";
import * as THREE from "three";
import { GLTFLoader } from "three/examples/jsm/loaders/GLTFLoader.js";
const data = readFileSync(process.argv[2]);
const buf = data.buffer.slice(data.byteOffset, data.byteOffset + data.byteLength);
new GLTFLoader().parse(buf, "", (gltf) => {
  const out = { animations: gltf.animations.map(a => ({ name: a.name, tracks: a.tracks.length, duration: a.duration })) };
  let mesh = null;
  gltf.scene.traverse(o => { if (o.isSkinnedMesh && !mesh) mesh = o; });
  out.skinned = !!mesh;
  out.bones = mesh ? mesh.skeleton.bones.length : 0;
  out.morphTargets = mesh && mesh.geometry.morphAttributes.position ? mesh.geometry.morphAttributes.position.length : 0;
  const times = process.argv.slice(3).map(Number);
  if (gltf.animations.length) {
    const mixer = new THREE.AnimationMixer(gltf.scene);
    mixer.clipAction(gltf.animations[0]).play();
    out.frames = [];
    for (const t of times) {
      mixer.setTime(t);
      gltf.scene.updateMatrixWorld(true);
      mesh.skeleton.update();
      const pos = [];
      const v = new THREE.Vector3();
      for (let i = 0; i < 5; i++) { mesh.getVertexPosition(i, v); v.applyMatrix4(mesh.matrixWorld); pos.push([v.x, v.y, v.z]); }
      out.frames.push(pos);
    }
  }
  console.log(JSON.stringify(out));
}, (err) => { console.error("LOAD ERROR", err); process.exit(1); });
