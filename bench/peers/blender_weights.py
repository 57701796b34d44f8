"""Blender's automatic weights (bone heat) on the dev assets' own skeletons, for `rigforge eval skin --peers`.

Runs in two halves. The outer half (the project's venv) reads every rigged asset with our glTF reader and
hands Blender plain arrays; the inner half runs inside a separate venv with `bpy==5.0.1` and `numpy<2`
(bpy 5.0.1's requirement, so it cannot share the project's numpy 2 venv), which this script creates on
first use in bench/peers/.venv-blender (git-ignored, ~350 MB from PyPI).

Blender setup, as a user would do it: duplicate vertices merged first (Blender's bone heat sees every
flat-shaded triangle as an island and returns nothing otherwise; merged here with simcore's weld and mapped
back so all copies get the welded vertex's weights), one bone per joint (head = joint, tail = its child, the mean of its
children, or continuing the parent bone for leaves; at least 1 % of the model size so no bone is dropped
as zero-length), vertex groups named after the joints, Object > Parent > With Automatic Weights.

  .venv/bin/python bench/peers/blender_weights.py [ASSETS_DIR] [--out bench/results/peers/blender]

Writes OUT/<asset>.npz: weights (V, J) float32 in the asset's vertex and joint order, seconds (the parenting
call alone), and OUT/summary.json.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the project's types; its modules are imported lazily (the bpy venv has none of them)
    from simcore.geometry.weld import WeldedMesh
    from simcore.io.gltf_rig import RiggedAsset

HERE = Path(__file__).resolve().parent
VENV = HERE / ".venv-blender"
BPY_SPEC = ["bpy==5.0.1", "numpy<2"]


def _inner(job: Path, out: Path) -> None:
    """Inside the bpy venv: arrays in `job` → Blender automatic weights → `out` (npz)."""
    import bpy  # noqa: PLC0415 (only importable inside the bpy venv)
    import numpy as np  # noqa: PLC0415

    data = np.load(job, allow_pickle=False)
    verts, faces, pos, parents = data["vertices"], data["faces"], data["positions"], data["parents"]
    names = [str(n) for n in data["names"]]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mesh = bpy.data.meshes.new("mesh")
    mesh.from_pydata(verts.tolist(), [], faces.tolist())
    mesh.update()
    obj = bpy.data.objects.new("mesh", mesh)
    bpy.context.scene.collection.objects.link(obj)
    size = float(np.ptp(verts, axis=0).max())

    arm_data = bpy.data.armatures.new("armature")
    arm = bpy.data.objects.new("armature", arm_data)
    bpy.context.scene.collection.objects.link(arm)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode="EDIT")
    children: list[list[int]] = [[] for _ in names]
    for j, p in enumerate(parents):
        if p >= 0:
            children[p].append(j)
    min_len = 0.01 * size
    bones = []
    for j, name in enumerate(names):
        bone = arm_data.edit_bones.new(name)
        head = pos[j]
        if children[j]:
            tail = pos[children[j]].mean(axis=0)
        elif parents[j] >= 0:
            tail = head + 0.5 * (head - pos[parents[j]])
        else:
            tail = head + np.array([0.0, min_len, 0.0])
        if np.linalg.norm(tail - head) < min_len:
            d = tail - head
            d = d / np.linalg.norm(d) if np.linalg.norm(d) > 1e-12 else np.array([0.0, 1.0, 0.0])
            tail = head + d * min_len
        bone.head, bone.tail = head.tolist(), tail.tolist()
        bones.append(bone)
    for j, p in enumerate(parents):
        if p >= 0:
            bones[j].parent = bones[p]
    bpy.ops.object.mode_set(mode="OBJECT")

    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    arm.select_set(True)
    bpy.context.view_layer.objects.active = arm
    started = time.perf_counter()
    bpy.ops.object.parent_set(type="ARMATURE_AUTO")
    seconds = time.perf_counter() - started

    weights = np.zeros((len(mesh.vertices), len(names)), np.float32)
    col = {g.index: names.index(g.name) for g in obj.vertex_groups if g.name in names}
    for v in mesh.vertices:
        for g in v.groups:
            if g.group in col:
                weights[v.index, col[g.group]] = g.weight
    np.savez_compressed(out, weights=weights, seconds=np.float64(seconds))


def ensure_venv() -> Path:
    """The bpy venv's python, creating the venv with pip on first use."""
    python = VENV / "bin" / "python"
    probe = [str(python), "-c", "import bpy, numpy"]
    if python.exists() and subprocess.run(probe, capture_output=True).returncode == 0:
        return python
    subprocess.run([sys.executable, "-m", "venv", str(VENV)], check=True)
    subprocess.run([str(python), "-m", "pip", "install", "-q", *BPY_SPEC], check=True)
    return python


def write_job(asset: RiggedAsset, job: Path) -> WeldedMesh:
    """Write the arrays Blender gets for `asset` to `job` (npz): the welded mesh (Blender's "merge by distance",
    done here) and the skeleton. Returns the weld, whose `index` maps Blender's weights back to every vertex."""
    import numpy as np  # noqa: PLC0415

    from simcore.geometry.weld import weld_vertices  # noqa: PLC0415

    s = asset.skeleton
    welded = weld_vertices(asset.vertices, asset.faces)
    np.savez(job, vertices=welded.vertices, faces=welded.faces, positions=s.positions, parents=s.parents, names=np.array(s.names))
    return welded


def run_job(python: Path, job: Path, out: Path) -> tuple[float, str | None]:
    """Run Blender on `job` in a fresh process writing `out`; (wall seconds, error line or None)."""
    started = time.perf_counter()
    proc = subprocess.run([str(python), __file__, "--inner", str(job), str(out)], capture_output=True, text=True)
    wall = time.perf_counter() - started
    if proc.returncode != 0:
        return wall, proc.stderr.strip().splitlines()[-1][:200] if proc.stderr.strip() else f"exit {proc.returncode}"
    return wall, None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("assets", nargs="?", default=str(HERE.parents[2] / "shared" / "assets" / "dev"))
    parser.add_argument("--out", default=str(HERE.parent / "results" / "peers" / "blender"))
    parser.add_argument("--inner", nargs=2, metavar=("JOB", "OUT"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.inner:
        _inner(Path(args.inner[0]), Path(args.inner[1]))
        return

    import numpy as np  # noqa: PLC0415

    sys.path.insert(0, str(HERE.parents[1]))
    from simcore.evaluation.assets import rigged_assets  # noqa: PLC0415

    python = ensure_venv()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    summary = {}
    for name, _category, _doc, asset in rigged_assets(Path(args.assets)):
        with tempfile.TemporaryDirectory() as tmp:
            job = Path(tmp) / "job.npz"
            welded = write_job(asset, job)
            wall, error = run_job(python, job, out / f"{name}.npz")
        if error:
            summary[name] = {"error": error}
        else:
            result = np.load(out / f"{name}.npz")
            seconds = float(result["seconds"])
            np.savez_compressed(out / f"{name}.npz", weights=result["weights"][welded.index], seconds=np.float64(seconds))
            summary[name] = {"seconds": round(seconds, 3), "process_seconds": round(wall, 2)}
        print(f"{name:28s} {summary[name]}", flush=True)
    (out / "summary.json").write_text(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
