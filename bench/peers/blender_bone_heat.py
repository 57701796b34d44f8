"""Inside the bpy venv: Blender's automatic weights (bone heat) for one rigged GLB, set up as a user would.

Run by bench/peers/blender_weights.py as `python blender_bone_heat.py JOB OUT` with the bpy venv's python
(this file imports nothing from the project). The file is imported with Blender's glTF importer (its
defaults), so the armature is Blender's own (bones, bind pose, the file's node transforms: the model at its
imported size, Z up). The mesh parented to it is the asset's welded bind mesh from JOB, placed onto those
bones by the similarity that takes our joint positions onto the bone heads: vertex i of JOB is vertex i in
Blender, so weights map back exactly (the imported mesh objects are removed; their positions come back as
`imported` for a check). Then Object > Parent > With Automatic Weights.

JOB (npz): source (path), names (J,) the joints' bone names as the importer gives them, positions (J, 3) and
vertices (U, 3) in bind space, faces (F, 3), placement (4, 4) bind space → Blender world, used when fewer than
3 bone heads match a joint name; bone_heuristic, the importer's "Bone Dir" (FORTUNE: a bone's tail on its
child, what bone heat needs; the default BLENDER points bones along the node's axis).
OUT (npz): heat (U, J) float32 in JOB's joint order; joints_matched (bones found for JOB's names);
seconds (the parenting call alone); fit ("heads" or
"placement"), fit_residual (largest joint-to-head distance / model size), scale, imported (N, 3) world
positions of the imported rig meshes' vertices, placed (U, 3) JOB's vertices where they were put.

Blender's messages ("Bone Heat Weighting: failed to find solution for one or more bones") go to this
process's stdout, which the caller reads.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import bpy
import numpy as np


def similarity(src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """(4, 4) scale·rotation + translation taking points src (K, 3) onto dst (K, 3), least squares (Umeyama)."""
    mu_s, mu_d = src.mean(axis=0), dst.mean(axis=0)
    a, b = src - mu_s, dst - mu_d
    u, s, vt = np.linalg.svd(b.T @ a / len(src))
    d = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))])
    scale = float((s * np.diag(d)).sum() / max((a**2).sum() / len(src), 1e-30))
    out = np.eye(4)
    out[:3, :3] = scale * (u @ d @ vt)
    out[:3, 3] = mu_d - out[:3, :3] @ mu_s
    return out


def _rig(names: list[str]) -> tuple[bpy.types.Object, list[bpy.types.Object]]:
    """The imported armature holding most of `names` and the mesh objects it deforms or carries."""
    armatures = [o for o in bpy.data.objects if o.type == "ARMATURE"]
    if not armatures:
        raise RuntimeError("the glTF importer made no armature")
    wanted = set(names)
    arm = max(armatures, key=lambda o: sum(b.name in wanted for b in o.data.bones))
    meshes = [o for o in bpy.data.objects if o.type == "MESH" and (
        o.parent == arm or any(m.type == "ARMATURE" and m.object == arm for m in o.modifiers))]
    return arm, meshes


def _world_coords(obj: bpy.types.Object) -> np.ndarray:
    mw = np.array(obj.matrix_world)
    co = np.array([v.co for v in obj.data.vertices]).reshape(-1, 3)
    return co @ mw[:3, :3].T + mw[:3, 3]


def bone_heat(job: Path, out: Path) -> None:
    """Import JOB's file, parent JOB's mesh to its armature With Automatic Weights, write OUT (module doc)."""
    data = np.load(job, allow_pickle=False)
    names = [str(n) for n in data["names"]]
    column = {n: j for j, n in enumerate(names)}
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=str(data["source"]), bone_heuristic=str(data["bone_heuristic"]))
    arm, imported = _rig(names)
    for bone in arm.data.bones:  # only the skin's joints take weights (the importer adds bones for other nodes)
        bone.use_deform = bone.name in column

    aw = np.array(arm.matrix_world)
    found = [(column[b.name], aw[:3, :3] @ np.array(b.head_local) + aw[:3, 3]) for b in arm.data.bones if b.name in column]
    positions = data["positions"]
    size = float(np.ptp(positions, axis=0).max()) or 1.0
    fit, place = "placement", data["placement"]
    if len(found) >= 3:
        idx = np.array([j for j, _ in found])
        heads = np.array([h for _, h in found])
        candidate = similarity(positions[idx], heads)
        if np.linalg.matrix_rank(positions[idx] - positions[idx].mean(axis=0), tol=1e-6 * size) >= 2:
            fit, place = "heads", candidate
    scale = float(np.cbrt(abs(np.linalg.det(place[:3, :3]))))
    mapped = positions @ place[:3, :3].T + place[:3, 3]
    residual = max((float(np.linalg.norm(mapped[j] - h)) for j, h in found), default=float("nan")) / (size * scale)

    coords = np.concatenate([_world_coords(o) for o in imported]) if imported else np.zeros((0, 3))
    for obj in imported:
        bpy.data.objects.remove(obj, do_unlink=True)
    placed = data["vertices"] @ place[:3, :3].T + place[:3, 3]
    mesh = bpy.data.meshes.new("mesh")
    mesh.from_pydata(placed.tolist(), [], data["faces"].tolist())
    mesh.update()
    obj = bpy.data.objects.new("mesh", mesh)
    bpy.context.scene.collection.objects.link(obj)

    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    arm.select_set(True)
    bpy.context.view_layer.objects.active = arm
    started = time.perf_counter()
    bpy.ops.object.parent_set(type="ARMATURE_AUTO")
    seconds = time.perf_counter() - started
    sys.stdout.flush()

    heat = np.zeros((len(mesh.vertices), len(names)), np.float32)
    col = {g.index: column[g.name] for g in obj.vertex_groups if g.name in column}
    for v in mesh.vertices:
        for g in v.groups:
            if g.group in col:
                heat[v.index, col[g.group]] = g.weight
    np.savez_compressed(out, heat=heat, joints_matched=np.int64(len(found)), seconds=np.float64(seconds), fit=np.str_(fit),
                        fit_residual=np.float64(residual), scale=np.float64(scale), imported=coords, placed=placed)


if __name__ == "__main__":
    bone_heat(Path(sys.argv[1]), Path(sys.argv[2]))
