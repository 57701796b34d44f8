"""Skinning speed on a large generated creature: skin (each method) + rigged GLB and USD export, target ≤ 10 s;
the learned method's own target is ≤ 3 s of skinning with its model already loaded (a worker loads it once).

The creature: a 12-joint spine with six 8-joint limbs (60 joints) built as a soup of capsules, one per bone,
at the resolution that first reaches the asked vertex count (~50k), ingested like an upload so vertex order is
the exported file's. The creature is built in a child process, so `peak_rss_mib` (this process's peak resident
memory after each method: ingest, model, skinning and export, as a worker holds them) leaves out building it; the
memory target is ≤ 2 GB at 1M vertices. Prints a table and writes bench/results/skinning.json.

  .venv/bin/python bench/skinning.py [--vertices 50000] [--methods learned geodesic heat auto]
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import platform
import resource
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import trimesh
from rich.console import Console
from rich.table import Table

from simcore.ingest import ingest
from simcore.io.glb_rig_writer import write_rigged_glb
from simcore.io.usd_skel_writer import write_usd_skel
from simcore.skeleton.types import Skeleton
from simcore.skinning.learned import load_model
from simcore.skinning.predict import compute_weights

TARGET_S = 10.0
LEARNED_TARGET_S = 3.0
PEAK_TARGET_MIB = 2e9 / 2**20  # ≤ 2 GB at 1M vertices
RESULTS = Path(__file__).resolve().parent / "results" / "skinning.json"


def creature(target_vertices: int) -> tuple[bytes, Skeleton]:
    """(GLB bytes of a capsule-soup creature, its 60-joint skeleton), about `target_vertices` vertices."""
    pos, parents = [[0.0, 0.5, 0.0]], [-1]
    for k in range(1, 12):  # spine along +Y
        pos.append([0.0, 0.5 + 0.12 * k, 0.0])
        parents.append(k - 1)
    for limb in range(6):
        attach = 3 + (limb // 2) * 3
        angle = np.deg2rad(25.0 + 20.0 * (limb // 2)) * (1 if limb % 2 else -1)
        direction = np.array([np.cos(angle) * (1 if limb % 2 else -1), -0.3, 0.2 * (limb // 2 - 1)])
        direction /= np.linalg.norm(direction)
        prev = attach
        for k in range(8):
            pos.append(list(np.asarray(pos[attach]) + direction * 0.1 * (k + 1)))
            parents.append(prev)
            prev = len(pos) - 1
    pos_a = np.asarray(pos)
    skeleton = Skeleton(pos_a, np.asarray(parents), [f"j{k:02d}" for k in range(len(pos))]).validate()

    def soup(count: int) -> trimesh.Trimesh:
        parts = []
        for p, c in skeleton.bones():
            a, b = pos_a[p], pos_a[c]
            length = float(np.linalg.norm(b - a))
            mesh = trimesh.creation.capsule(height=length, radius=0.07 if c < 12 else 0.035, count=[count, count])
            mesh.apply_transform(trimesh.geometry.align_vectors([0.0, 0.0, 1.0], (b - a) / length))
            mesh.apply_translation((a + b) / 2.0)
            parts.append(mesh)
        out = trimesh.util.concatenate(parts)
        assert isinstance(out, trimesh.Trimesh)  # trimesh types it as any Geometry; capsules concatenate to a Trimesh
        return out

    # capsule resolution: the first whose soup reaches the asked vertex count (vertices grow as its square)
    count = max(4, int(16 * np.sqrt(target_vertices / len(soup(16).vertices))) - 2)
    while len((mesh := soup(count)).vertices) < target_vertices:
        count += 1
    v, f = mesh.vertices, mesh.faces
    glb = trimesh.Trimesh(v, f, process=False).export(file_type="glb")
    assert isinstance(glb, bytes)  # export() is typed for every format; GLB is bytes
    return glb, skeleton


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--vertices", type=int, default=50_000)
    parser.add_argument("--methods", nargs="+", default=["learned", "geodesic", "heat", "auto"])
    args = parser.parse_args()
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        glb, skeleton = pool.submit(creature, args.vertices).result()
    mesh = ingest(glb, "glb")
    del glb
    rows = []
    started = time.perf_counter()
    load_model()
    load_s = round(time.perf_counter() - started, 3)
    for method in args.methods:
        started = time.perf_counter()
        result = compute_weights(mesh.vertices, mesh.faces, skeleton, method=method)
        skin_s = time.perf_counter() - started
        started = time.perf_counter()
        write_rigged_glb(mesh.glb, skeleton, result.weights)
        glb_s = time.perf_counter() - started
        with tempfile.TemporaryDirectory() as tmp:
            started = time.perf_counter()
            write_usd_skel(mesh.glb, skeleton, result.weights, Path(tmp) / "rigged.usdc", usdz_path=Path(tmp) / "rigged.usdz")
            usd_s = time.perf_counter() - started
        export_s = glb_s + usd_s
        rows.append({
            "method": method, "chosen": result.method, "vertices": len(mesh.vertices), "joints": skeleton.num_joints,
            "skin_s": round(skin_s, 3), "glb_s": round(glb_s, 3), "usd_s": round(usd_s, 3), "total_s": round(skin_s + export_s, 3),
            "target_s": TARGET_S, "ok": skin_s + export_s <= TARGET_S and (result.method != "learned" or skin_s <= LEARNED_TARGET_S),
            "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024,
        })
    table = Table(title=f"Skinning speed ({platform.processor() or platform.machine()}, target ≤ {TARGET_S:g} s skin + export)")
    for key in rows[0]:
        table.add_column(key, justify="right")
    for row in rows:
        table.add_row(*[str(v) for v in row.values()])
    Console(width=160).print(table)
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    Console().print(f"learned model load (once per worker process): {load_s} s")
    RESULTS.write_text(json.dumps({"rows": rows, "learned_model_load_s": load_s, "learned_target_s": LEARNED_TARGET_S,
                                   "peak_target_mib": round(PEAK_TARGET_MIB)}, indent=1))


if __name__ == "__main__":
    main()
