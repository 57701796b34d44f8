"""Skeleton speed: the geometric and humanoid methods on ~50k-vertex meshes (target ≤ 5 s on 2 cores).

Meshes: a generated capsule quadruped and a generated capsule biped, tessellated to ≥ 50k vertices, plus the
dev Xbot (28k vertices) Loop-subdivided past 50k when ../shared is beside the repo. Reference in the same
run: a plain scikit-image skeletonisation of the same voxel grid (no graph, no joints), the floor any
thinning-based method pays. Prints a table and writes bench/results/skeleton.json.

    .venv/bin/python bench/skeleton.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import TypeVar

import numpy as np
import trimesh

from simcore.geometry.capsule_creatures import quadruped, stick_humanoid
from simcore.geometry.voxelize import solid_voxels
from simcore.skeleton.geometric import GeometricParams
from simcore.skeleton.predict import predict_skeleton

REPO = Path(__file__).resolve().parents[1]
DEV = Path(os.environ.get("RIGFORGE_DEV_ASSETS", REPO.parent / "shared" / "assets" / "dev"))
TARGET_VERTICES = 50_000
BUDGET_S = 5.0
T = TypeVar("T")


def meshes() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    out = {"capsule_quadruped": quadruped(count=66)[:2]}
    out["capsule_biped"] = stick_humanoid(count=50)[:2]
    xbot = DEV / "xbot.glb"
    if xbot.exists():
        from simcore.io.gltf_document import GltfDocument
        from simcore.io.gltf_rig import read_rigged_asset

        asset = read_rigged_asset(GltfDocument.from_bytes(xbot.read_bytes()))
        mesh = trimesh.Trimesh(asset.vertices, asset.faces, process=False)
        while len(mesh.vertices) < TARGET_VERTICES:
            mesh = mesh.subdivide()
        out["xbot_subdivided"] = (np.asarray(mesh.vertices), np.asarray(mesh.faces))
    return out


def timed(fn: Callable[[], T], repeat: int) -> tuple[float, T]:
    times: list[float] = []
    for _ in range(repeat):
        started = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - started)
    return float(np.median(times)), result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    from skimage.morphology import skeletonize

    def reference(v: np.ndarray, f: np.ndarray) -> np.ndarray:
        return skeletonize(solid_voxels(v, f, GeometricParams().resolution).occupancy)

    rows = []
    for name, (v, f) in meshes().items():
        ref_s, _ = timed(partial(reference, v, f), args.repeat)
        rows.append({"mesh": name, "vertices": len(v), "faces": len(f), "method": "reference: voxelise + skeletonize",
                     "seconds": round(ref_s, 3), "joints": None})
        for method in ("geometric", "auto"):
            secs, pred = timed(partial(predict_skeleton, v, f, method=method), args.repeat)
            rows.append({"mesh": name, "vertices": len(v), "faces": len(f), "method": f"{method} → {pred.method}",
                         "seconds": round(secs, 3), "joints": pred.skeleton.num_joints,
                         "within_budget": secs <= BUDGET_S})
    header = f"{'mesh':20s} {'vertices':>9s} {'method':36s} {'seconds':>8s} {'joints':>7s}"
    print(header)
    print("-" * len(header))
    for r in rows:
        print(f"{r['mesh']:20s} {r['vertices']:9d} {r['method']:36s} {r['seconds']:8.3f} {str(r['joints'] or '-'):>7s}")
    out = REPO / "bench" / "results" / "skeleton.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"budget_s": BUDGET_S, "repeat": args.repeat, "cpus": os.cpu_count(),
                               "machine": platform.platform(), "rows": rows}, indent=2))
    print(f"wrote {out.relative_to(REPO)}")


if __name__ == "__main__":
    main()
