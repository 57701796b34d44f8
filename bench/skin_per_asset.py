"""Skinning time per dev asset, ours beside Blender's automatic weights, on the artist's skeleton.

Two levels:
  call:    the weight computation alone, in a warm process (ours: `compute_weights`, `auto` = both methods
           + scores; Blender: the `parent_set(ARMATURE_AUTO)` operator, timed inside its process);
  process: a fresh interpreter per asset that reads the mesh and skeleton, computes, and writes the weights
           (Python start, imports and first-call set-up included, as Blender's bpy start is).
Both processes run here, alternately, `--repeats` times per asset (median kept): this VM's timings drift by
±10 % over minutes, so figures from separate runs do not compare. Blender runs in the bpy venv that
bench/peers/blender_weights.py makes (run that first); without it only our rows are timed.
Prints a table and writes bench/results/skin_per_asset.json.

  .venv/bin/python bench/skin_per_asset.py [DIR] [--repeats 3]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from types import ModuleType
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


def _ours_process(job: Path, out: Path) -> float:
    """Wall seconds of one fresh process of ours on `job` (see `_inner`)."""
    started = time.perf_counter()
    subprocess.run([sys.executable, __file__, "--inner", str(job), str(out)], check=True)
    return time.perf_counter() - started


def _call_seconds(vertices: np.ndarray, faces: np.ndarray, skeleton: Skeleton, repeats: int) -> float:
    """Median warm-call time of `auto` (the first call is not counted)."""
    from simcore.skinning.predict import compute_weights  # noqa: PLC0415

    compute_weights(vertices, faces, skeleton)
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        compute_weights(vertices, faces, skeleton)
        times.append(time.perf_counter() - started)
    return float(np.median(times))


def _blender() -> tuple[Path | None, ModuleType]:
    """The bpy venv's python (None when the peer script has not made it) and the peer module."""
    sys.path.insert(0, str(HERE / "peers"))
    import blender_weights  # noqa: PLC0415

    python = blender_weights.VENV / "bin" / "python"
    return (python if python.exists() else None), blender_weights


def _table(rows: list[dict]) -> dict:
    """Print the per-asset table; return the summary (how often and by how much ours is faster)."""
    from rich.console import Console  # noqa: PLC0415 - not imported by the timed inner process
    from rich.table import Table  # noqa: PLC0415

    table = Table(title="Skinning per asset, seconds, median (ours: auto; Blender: automatic weights)")
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
    Console().print(summary or "no Blender rows: run bench/peers/blender_weights.py first")
    return summary


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("assets", nargs="?", default=str(HERE.parents[1] / "shared" / "assets" / "dev"))
    parser.add_argument("--repeats", type=int, default=3, help="fresh processes per asset and tool (median kept)")
    parser.add_argument("--inner", nargs=2, metavar=("JOB", "OUT"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.inner:
        _inner(Path(args.inner[0]), Path(args.inner[1]))
        return

    from simcore.evaluation.assets import rigged_assets  # noqa: PLC0415

    python, peer = _blender()
    rows = []
    for name, _category, doc, asset in rigged_assets(Path(args.assets)):
        s = asset.skeleton
        ours, theirs, blender_calls = [], [], []
        with tempfile.TemporaryDirectory() as tmp:
            job, blender_job, out = Path(tmp) / "job.npz", Path(tmp) / "blender_job.npz", Path(tmp) / "out.npz"
            np.savez(job, vertices=asset.vertices, faces=asset.faces, positions=s.positions, parents=s.parents, names=np.array(s.names))
            if python is not None:
                peer.write_job(asset, blender_job, next(Path(args.assets).glob(f"{name}.gl*")), doc)
            for _ in range(args.repeats):  # alternate, so drift on this VM hits both tools alike
                ours.append(_ours_process(job, out))
                if python is not None:
                    wall, error, _output = peer.run_job(python, blender_job, out)
                    if error is None:
                        theirs.append(wall)
                        blender_calls.append(float(np.load(out)["seconds"]))
        median = lambda xs: round(float(np.median(xs)), 3) if xs else None  # noqa: E731
        rows.append({"name": name, "vertices": len(asset.vertices), "joints": s.num_joints,
                     "ours_call": round(_call_seconds(asset.vertices, asset.faces, s, args.repeats), 3),
                     "ours_process": median(ours), "blender_call": median(blender_calls), "blender_process": median(theirs),
                     "ours_process_runs": [round(x, 3) for x in ours], "blender_process_runs": [round(x, 3) for x in theirs]})
        print({k: v for k, v in rows[-1].items() if not k.endswith("_runs")}, flush=True)
    summary = _table(rows)
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps({"assets": rows, "summary": summary, "repeats": args.repeats}, indent=1))


if __name__ == "__main__":
    main()
