"""Blender's automatic weights (bone heat) on rigged assets' own skeletons, for `rigforge eval skin` peer rows.

Runs in two halves. This one (the project's venv) reads every rigged asset with our glTF reader; the other,
bench/peers/blender_bone_heat.py, runs inside a separate venv with `bpy==5.0.1` and `numpy<2` (bpy 5.0.1's
requirement, so it cannot share the project's numpy 2 venv), which this script creates on first use in
bench/peers/.venv-blender (git-ignored, ~1 GB from PyPI).

Blender setup, as a user would do it: the file imported with Blender's glTF importer (its armature, bones and
node transforms, so the model is at its imported size: a ×100 scale node gives metres, not centimetres;
"Bone Dir" Fortune, which puts each bone's tail on its child as a user rigging with bone heat would: the
default, Blender, points bones along the nodes' axes and bone heat then scores L1 ~1.1 instead of ~0.53);
duplicate vertices merged first (Blender's bone heat sees every flat-shaded triangle as an island and returns
nothing otherwise; merged here with simcore's weld and mapped back so all copies get the welded vertex's
weights); only the skin's joints deform; Object > Parent > With Automatic Weights. The mesh Blender weights
is our welded bind mesh placed onto the imported bones (see blender_bone_heat.py), so vertex i maps back
exactly; `import_match` checks it against the importer's own mesh.

Blender's messages are kept: a "failed to find solution" is status `failed`, vertices left without any weight
make it `partial` (share in `unweighted_share`), and an asset Blender could not be run on is `error`.

  .venv/bin/python bench/peers/blender_weights.py [DIR] [--split val] [--out bench/results/peers/blender]

Writes OUT/<asset>.npz: weights (V, J) float32 in the asset's vertex and joint order (zeros for `error`),
status, unweighted_share, seconds (the parenting call alone), messages; and OUT/summary.json (or
summary-<split>.json).
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

import numpy as np

if TYPE_CHECKING:
    from simcore.geometry.weld import WeldedMesh
    from simcore.io.gltf_document import GltfDocument
    from simcore.io.gltf_rig import RiggedAsset

HERE = Path(__file__).resolve().parent
VENV = HERE / ".venv-blender"
BPY_SPEC = ["bpy==5.0.1", "numpy<2"]
INNER = HERE / "blender_bone_heat.py"
FAILED_MESSAGE = "failed to find solution"  # Blender's "Bone Heat Weighting: failed to find solution for one or more bones"
Y_UP_TO_Z_UP = np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])  # glTF frame → Blender's
UNWEIGHTED = 1e-6  # a vertex whose Blender weights sum to no more than this has none


def ensure_venv() -> Path:
    """The bpy venv's python, creating the venv with pip on first use."""
    python = VENV / "bin" / "python"
    probe = [str(python), "-c", "import bpy, numpy"]
    if python.exists() and subprocess.run(probe, capture_output=True).returncode == 0:
        return python
    subprocess.run([sys.executable, "-m", "venv", str(VENV)], check=True)
    subprocess.run([str(python), "-m", "pip", "install", "-q", *BPY_SPEC], check=True)
    return python


def write_job(asset: RiggedAsset, job: Path, source: Path, doc: GltfDocument | None = None, bone_heuristic: str = "FORTUNE") -> WeldedMesh:
    """Write what Blender gets for `asset` (read from `source`) to `job` (npz): the file, the joints, the welded
    bind mesh (Blender's "merge by distance", done here) and the bind → Blender-world placement. Returns the
    weld, whose `index` maps Blender's weights back to every vertex."""
    from simcore.geometry.weld import weld_vertices  # noqa: PLC0415
    from simcore.io.gltf_document import GltfDocument  # noqa: PLC0415
    from simcore.motion.gltf_clips import bind_placement  # noqa: PLC0415

    doc = doc or GltfDocument.from_bytes(source.read_bytes())
    s = asset.skeleton
    welded = weld_vertices(asset.vertices, asset.faces)
    np.savez(job, source=np.str_(source.resolve()), names=np.array(importer_bone_names(doc, asset)), positions=s.positions,
             vertices=welded.vertices, faces=welded.faces, placement=Y_UP_TO_Z_UP @ bind_placement(doc, asset),
             bone_heuristic=np.str_(bone_heuristic))
    return welded


def importer_bone_names(doc: GltfDocument, asset: RiggedAsset) -> list[str]:
    """The name Blender's glTF importer gives each joint's bone, in our joint order: the node's name, or
    "Node_<index>" for an unnamed node, cut to Blender's 63 bytes."""
    nodes = doc.items("nodes")
    names = [str(nodes[n].get("name") or f"Node_{n}") for n in asset.joint_nodes]
    return [n.encode()[:63].decode(errors="ignore") for n in names]


def run_job(python: Path, job: Path, out: Path) -> tuple[float, str | None, str]:
    """Run Blender on `job` in a fresh process writing `out`: (wall seconds, error line or None, its output)."""
    started = time.perf_counter()
    proc = subprocess.run([str(python), str(INNER), str(job), str(out)], capture_output=True, text=True)
    wall = time.perf_counter() - started
    output = proc.stdout + proc.stderr
    if proc.returncode != 0:
        return wall, proc.stderr.strip().splitlines()[-1][:200] if proc.stderr.strip() else f"exit {proc.returncode}", output
    return wall, None, output


def blender_messages(output: str) -> list[str]:
    """Blender's warnings and errors in a run's output (the importer's INFO lines left out)."""
    return [line.strip() for line in output.splitlines() if "Bone Heat" in line or line.lstrip().startswith(("Warning", "Error"))]


def solve_status(weights: np.ndarray, messages: list[str]) -> tuple[str, float]:
    """(status, unweighted share) of Blender's (V, J) weights: `failed` when Blender found no solution (it
    stops at the failing bone), `partial` when some vertices got no weight, else `ok`."""
    unweighted = float(np.mean(weights.sum(axis=1) <= UNWEIGHTED)) if len(weights) else 1.0
    if unweighted >= 1.0 or any(FAILED_MESSAGE in m for m in messages):
        return "failed", unweighted
    return ("partial" if unweighted > 0 else "ok"), unweighted


def import_match(placed: np.ndarray, imported: np.ndarray, size: float) -> float | None:
    """Share of our placed vertices within 1e-4 × size of a vertex of the imported mesh (1.0: same place;
    parts a bone carries may sit elsewhere in Blender's rest pose). None without imported vertices."""
    from scipy.spatial import cKDTree  # noqa: PLC0415

    if len(imported) == 0 or len(placed) == 0:
        return None
    dist, _ = cKDTree(imported).query(placed)
    return float(np.mean(dist <= 1e-4 * size))


def blender_asset(python: Path, name: str, source: Path, doc: GltfDocument, asset: RiggedAsset, out: Path, bone_heuristic: str) -> dict:
    """Blender's weights for one asset → OUT/<name>.npz; returns its summary entry."""
    shape = asset.weights.shape
    with tempfile.TemporaryDirectory() as tmp:
        job, raw = Path(tmp) / "job.npz", Path(tmp) / "out.npz"
        welded = write_job(asset, job, source, doc, bone_heuristic)
        wall, error, output = run_job(python, job, raw)
        messages = blender_messages(output)
        if error is None:
            result = dict(np.load(raw, allow_pickle=False))
            if int(result["joints_matched"]) == 0:
                error = "no imported bone is named as a joint of the skin"
    if error is not None:
        np.savez_compressed(out / f"{name}.npz", weights=np.zeros(shape, np.float32), status=np.str_("error"),
                            unweighted_share=np.float64(1.0), seconds=np.float64(np.nan), messages=np.str_(error))
        return {"status": "error", "error": error, "messages": messages}
    weights = result["heat"][welded.index]
    status, unweighted = solve_status(weights, messages)
    size = float(np.ptp(result["placed"], axis=0).max()) if len(result["placed"]) else 1.0
    entry = {"status": status, "unweighted_share": round(unweighted, 4), "seconds": round(float(result["seconds"]), 3),
             "process_seconds": round(wall, 2),
             "joints_matched": f"{int(result['joints_matched'])}/{shape[1]}", "fit": str(result["fit"]),
             "fit_residual": float(f"{float(result['fit_residual']):.2g}"),
             "imported_scale": round(float(result["scale"]), 4), "size": round(size, 4),
             "import_match": import_match(result["placed"], result["imported"], size), "messages": messages}
    np.savez_compressed(out / f"{name}.npz", weights=weights.astype(np.float32), status=np.str_(status),
                        unweighted_share=np.float64(unweighted), seconds=result["seconds"], messages=np.str_("\n".join(messages)))
    return entry


def asset_files(directory: Path, split: str | None) -> list[Path]:
    """The .glb/.gltf files to run: MANIFEST.tsv's `split` (corpus layout) or every one in `directory`."""
    from simcore.evaluation.assets import split_files  # noqa: PLC0415

    if split:
        return split_files(directory, split)
    return sorted(p for p in directory.iterdir() if p.suffix.lower() in (".glb", ".gltf"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("assets", nargs="?", default=str(HERE.parents[2] / "shared" / "assets" / "dev"))
    parser.add_argument("--split", help="only the files DIR/MANIFEST.tsv lists for this split (train, val)")
    parser.add_argument("--bone-heuristic", default="FORTUNE", choices=("FORTUNE", "TEMPERANCE", "BLENDER"),
                        help="the glTF importer's Bone Dir (default FORTUNE: tails on children; BLENDER's node axes give L1 ~1.1)")
    parser.add_argument("--out", default=str(HERE.parent / "results" / "peers" / "blender"))
    args = parser.parse_args()

    sys.path.insert(0, str(HERE.parents[1]))
    from simcore.evaluation.assets import problem  # noqa: PLC0415
    from simcore.io.gltf_document import GltfDocument  # noqa: PLC0415
    from simcore.io.gltf_rig import read_rigged_asset  # noqa: PLC0415

    python = ensure_venv()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    summary: dict[str, dict] = {}
    for path in asset_files(Path(args.assets), args.split):
        try:
            doc = GltfDocument.from_bytes(path.read_bytes())
            asset = read_rigged_asset(doc)
        except Exception as exc:  # not a rig (no skin): nothing for Blender to weight, as in the evaluation
            print(f"{path.stem:28s} skipped: {problem(exc)}", flush=True)
            continue
        summary[path.stem] = blender_asset(python, path.stem, path, doc, asset, out, args.bone_heuristic)
        print(f"{path.stem:28s} {summary[path.stem]}", flush=True)
    counts = {s: sum(e["status"] == s for e in summary.values()) for s in ("ok", "partial", "failed", "error")}
    print(counts)
    name = f"summary-{args.split}.json" if args.split else "summary.json"
    (out / name).write_text(json.dumps({"bone_heuristic": args.bone_heuristic, "assets": summary, "counts": counts}, indent=1))


if __name__ == "__main__":
    main()
