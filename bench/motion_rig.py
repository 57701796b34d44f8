"""Rigs from motion speed: a 5,000-vertex × 100-frame mesh sequence rigged from its motion (target ≤ 60 CPU s).

Sequence: a generated tube of 50 rings × 100 vertices skinned to a 12-joint chain, posed by a seeded random
motion (simcore.evaluation.motion_sequences.tube_sequence). Rows: the automatic bone count and a fixed one
(`--bones`). Reference in the same run: free-bone Dem Bones alone at the count each row chose (what the rig adds
on top is joints, the tree, the re-fit and the shape joints). Wall and CPU seconds both: on shared cores the wall
time counts other work, so the budget is checked on CPU seconds (the solve runs on one thread). Prints a table and
writes bench/results/motion_rig.json.

    .venv/bin/python bench/motion_rig.py [--bones 24]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np

from simcore.evaluation.motion_sequences import tube_sequence
from simcore.motion_rig.free_bones import solve_free_bones
from simcore.motion_rig.sequence_weld import seam_triangles
from simcore.motion_rig.solve import MotionRigParams, rig_from_motion

REPO = Path(__file__).resolve().parents[1]
BUDGET_S = 60.0


def _timed(run):  # noqa: ANN001, ANN202
    wall, cpu = time.perf_counter(), time.process_time()
    out = run()
    return out, round(time.perf_counter() - wall, 2), round(time.process_time() - cpu, 2)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bones", type=int, default=24, help="the fixed bone count of the second row")
    args = parser.parse_args()
    seq = tube_sequence(50, 100, 12, 100, seed=7)
    surface = np.concatenate([seq.faces, seam_triangles(seq.frames, seq.faces)])
    rows = []
    for label, params in (("auto count", MotionRigParams()), (f"{args.bones} bones", MotionRigParams(bones=args.bones))):
        rig, wall, cpu = _timed(lambda params=params: rig_from_motion(seq.rest, seq.faces, seq.frames, seq.fps, params))
        bones = rig.report["motion_bones"]
        _, free_wall, free_cpu = _timed(lambda bones=bones: solve_free_bones(
            seq.rest, seq.frames, surface, bones, max_influences=4, iterations=MotionRigParams().iterations))
        rows.append({"row": label, "vertices": seq.rest.shape[0], "frames": seq.frames.shape[0], "bones": bones,
                     "shape_joints": rig.report["shape_joints"],
                     "rmse": rig.report["rmse"], "free_rmse": rig.report["free_bones_rmse"], "wall_s": wall,
                     "cpu_s": cpu, "within_budget": cpu <= BUDGET_S, "dem_bones_alone_wall_s": free_wall,
                     "dem_bones_alone_cpu_s": free_cpu, "count_search": rig.report["count_search"]})
    head = f"{'row':<12}{'V':>6}{'T':>5}{'bones':>6}{'shape':>6}{'rmse':>9}{'free':>9}{'wall s':>8}{'cpu s':>7}{'DB wall':>9}{'DB cpu':>8}"
    print(head)
    for r in rows:
        print(f"{r['row']:<12}{r['vertices']:>6}{r['frames']:>5}{r['bones']:>6}{r['shape_joints']:>6}{r['rmse']:>9.5f}{r['free_rmse']:>9.5f}"
              f"{r['wall_s']:>8.1f}{r['cpu_s']:>7.1f}{r['dem_bones_alone_wall_s']:>9.1f}{r['dem_bones_alone_cpu_s']:>8.1f}")
    out = REPO / "bench" / "results" / "motion_rig.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"budget_s": BUDGET_S, "machine": platform.processor() or platform.machine(),
                               "cores": os.cpu_count(), "load_average": os.getloadavg(), "rows": rows}, indent=1))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
