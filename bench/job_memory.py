"""Peak memory of a whole job against its mesh size: the figures behind simcore.job_cost's coefficients.

Runs the pipeline (ingest, skeleton, skin, export) on capsule creatures of about N vertices, each in a fresh
process, and reports the peak RSS above the process's size before the job, with the per-vertex slope between
sizes and what `simcore.job_cost` estimates for the same mesh. Prints a table and writes JSON.

  .venv/bin/python -m bench.job_memory [--vertices 60000 250000]
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rich.console import Console
from rich.table import Table

RESULTS = Path(__file__).parent / "results" / "job_memory.json"


def measure(target: int) -> dict:
    """In this process: build a creature, run the job, return its sizes, peak and estimate."""
    import torch

    from bench.skinning import creature
    from simcore.job_cost import stage_estimate
    from simcore.options import JobOptions
    from simcore.pipeline import PipelineInputs, run_pipeline

    torch.set_num_threads(1)
    glb, _ = creature(target)
    folder = Path(tempfile.mkdtemp())
    (folder / "creature.glb").write_bytes(glb)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    started = time.perf_counter()
    state = run_pipeline(PipelineInputs(folder / "creature.glb", "glb"), JobOptions(stages=["skeleton", "skin", "export"]),
                         folder / "out")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    estimate = stage_estimate("skeleton", state)
    assert state.mesh is not None and estimate is not None
    return {"vertices": len(state.mesh.vertices), "peak_above_start_mb": round((peak - before) / 2**20),
            "estimate_mb": round(estimate[0] / 2**20), "seconds": round(time.perf_counter() - started, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--vertices", type=int, nargs="+", default=[60_000, 250_000])
    parser.add_argument("--one", type=int, help=argparse.SUPPRESS)  # the child run of one size
    args = parser.parse_args()
    if args.one:
        print(json.dumps(measure(args.one)))
        return
    rows = []
    for n in args.vertices:
        out = subprocess.run([sys.executable, "-m", "bench.job_memory", "--one", str(n)], capture_output=True, text=True, check=True)
        rows.append(json.loads(out.stdout.strip().splitlines()[-1]))
    for a, b in zip(rows, rows[1:], strict=False):
        b["slope_bytes_per_vertex"] = round((b["peak_above_start_mb"] - a["peak_above_start_mb"]) * 2**20
                                            / max(b["vertices"] - a["vertices"], 1))
    table = Table(title="job peak memory (ingest, skeleton, skin, export)")
    for column in ("vertices", "peak above start MB", "estimate MB", "slope B/vertex", "s"):
        table.add_column(column, justify="right")
    for r in rows:
        table.add_row(f"{r['vertices']:,}", str(r["peak_above_start_mb"]), str(r["estimate_mb"]),
                      str(r.get("slope_bytes_per_vertex", "")), str(r["seconds"]))
    Console().print(table)
    RESULTS.parent.mkdir(exist_ok=True)
    RESULTS.write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
