"""Skinning time per dev asset, ours beside Blender's automatic weights, on the artist's skeleton.

Two levels, as for the peer (bench/peers/blender_weights.py, whose summary.json this reads):
  call:    the weight computation alone, in a warm process (ours: `compute_weights`, `auto` = both methods
           + scores; Blender: the `parent_set(ARMATURE_AUTO)` operator);
  process: a fresh interpreter per asset that reads the mesh and skeleton, computes, and writes the weights
           (Python start, imports and first-call set-up included, as Blender's bpy start is).
Prints a table and writes bench/results/skin_per_asset.json.

  .venv/bin/python bench/skin_per_asset.py [DIR] [--blender bench/results/peers/blender/summary.json]
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
    from simcore.skeleton.types import Skeleton

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results" / "skin_per_asset.json"


def _inner(job: Path, out: Path) -> None:
    """The fresh process: read the job, compute `auto` weights, write them (what the process level times)."""
    from simcore.skeleton.types import Skeleton  # noqa: PLC0415 - the imports are part of what is timed
    from simcore.skinning.predict import compute_weights  # noqa: PLC0415

    data = np.load(job)
    skeleton = Skeleton(data["positions"], data["parents"], [str(n) for n in data["names"]])
    weights = compute_weights(data["vertices"], data["faces"], skeleton).weights
    np.savez(out, weights=weights.toarray().astype(np.float32))


def _call_seconds(vertices: np.ndarray, faces: np.ndarray, skeleton: Skeleton, repeats: int = 3) -> float:
    """Median warm-call time of `auto` (the first call, which loads compiled code, is not counted)."""
    from simcore.skinning.predict import compute_weights  # noqa: PLC0415

    compute_weights(vertices, faces, skeleton)
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        compute_weights(vertices, faces, skeleton)
        times.append(time.perf_counter() - started)
    return float(np.median(times))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("assets", nargs="?", default=str(HERE.parents[1] / "shared" / "assets" / "dev"))
    parser.add_argument("--blender", default=str(HERE / "results" / "peers" / "blender" / "summary.json"))
    parser.add_argument("--inner", nargs=2, metavar=("JOB", "OUT"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.inner:
        _inner(Path(args.inner[0]), Path(args.inner[1]))
        return

    from rich.console import Console  # noqa: PLC0415 - not imported by the timed inner process
    from rich.table import Table  # noqa: PLC0415

    from simcore.evaluation.assets import rigged_assets  # noqa: PLC0415

    blender_path = Path(args.blender)
    blender = json.loads(blender_path.read_text()) if blender_path.is_file() else {}
    rows = []
    for name, _category, _doc, asset in rigged_assets(Path(args.assets)):
        s = asset.skeleton
        with tempfile.TemporaryDirectory() as tmp:
            job = Path(tmp) / "job.npz"
            np.savez(job, vertices=asset.vertices, faces=asset.faces, positions=s.positions, parents=s.parents, names=np.array(s.names))
            started = time.perf_counter()
            subprocess.run([sys.executable, __file__, "--inner", str(job), str(Path(tmp) / "out.npz")], check=True)
            process = time.perf_counter() - started
        peer = blender.get(name, {})
        rows.append({"name": name, "vertices": len(asset.vertices), "joints": s.num_joints,
                     "ours_call": round(_call_seconds(asset.vertices, asset.faces, s), 3), "ours_process": round(process, 2),
                     "blender_call": peer.get("seconds"), "blender_process": peer.get("process_seconds")})
        print(rows[-1], flush=True)

    table = Table(title="Skinning per asset, seconds (ours: auto; Blender: automatic weights)")
    for column in ("asset", "vertices", "joints", "ours call", "Blender call", "ours process", "Blender process"):
        table.add_column(column, justify="left" if column == "asset" else "right")
    fmt = lambda x: "—" if x is None else f"{x:.3f}"  # noqa: E731
    for r in rows:
        table.add_row(r["name"], str(r["vertices"]), str(r["joints"]), fmt(r["ours_call"]), fmt(r["blender_call"]),
                      fmt(r["ours_process"]), fmt(r["blender_process"]))
    Console().print(table)
    summary = {}
    for level in ("call", "process"):
        pairs = [(r[f"ours_{level}"], r[f"blender_{level}"]) for r in rows if r[f"blender_{level}"] is not None]
        if pairs:
            summary[level] = {"ours_faster_on": sum(o <= b for o, b in pairs), "assets": len(pairs),
                              "ours_mean": round(float(np.mean([o for o, _ in pairs])), 3),
                              "blender_mean": round(float(np.mean([b for _, b in pairs])), 3)}
    Console().print(summary or "no Blender results: run bench/peers/blender_weights.py first")
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps({"assets": rows, "summary": summary}, indent=1))


if __name__ == "__main__":
    main()
