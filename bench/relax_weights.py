"""Weight relaxation under a clip (the motion stage's `relax_weights`) on a large generated creature: seconds and
peak memory, target ≤ 10 s at 50k vertices.

The creature is `bench/skinning.py`'s capsule soup (60 joints), skinned with geodesic weights, built and skinned in a
child process so `peak_rss_mib` is this process's peak while it relaxes (the mesh, the weights and the relaxation, as
the motion stage holds them). The clip: FRAMES frames easing every joint between random poses (±40°), the kind of
whole-body motion that bends every blend. Prints a table and writes bench/results/relax_weights.json.

  .venv/bin/python -m bench.relax_weights [--vertices 50000] [--frames 120]
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import platform
import resource
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from rich.console import Console
from rich.table import Table
from scipy.spatial.transform import Rotation, Slerp

from simcore.motion.relax_weights import relax_weights
from simcore.skeleton.kinematics import global_transforms, rest_local_matrices, skinning_matrices
from simcore.skeleton.types import Skeleton

TARGET_S = 10.0
KEY_POSES = 5
DEGREES = 40.0
RESULTS = Path(__file__).resolve().parent / "results" / "relax_weights.json"


def skinned_creature(vertices: int) -> tuple[np.ndarray, np.ndarray, Skeleton, sp.csr_matrix]:
    """(vertices, faces, skeleton, geodesic weights) of the skinning bench's creature."""
    from bench.skinning import creature
    from simcore.ingest import ingest
    from simcore.skinning.predict import compute_weights

    glb, skeleton = creature(vertices)
    mesh = ingest(glb, "glb")
    return mesh.vertices, mesh.faces, skeleton, compute_weights(mesh.vertices, mesh.faces, skeleton, method="geodesic").weights


def clip(skeleton: Skeleton, frames: int, rng: np.random.Generator) -> np.ndarray:
    """(frames, J, 4, 4) skinning matrices easing every joint through KEY_POSES random rotations."""
    keys = np.linspace(0.0, 1.0, KEY_POSES)
    vectors = rng.uniform(-1, 1, (KEY_POSES, skeleton.num_joints, 3)) * np.deg2rad(DEGREES) / np.sqrt(3)
    vectors[0] = 0.0  # the clip starts at the bind pose
    times = np.linspace(0.0, 1.0, frames)
    rest = rest_local_matrices(skeleton)
    local = np.tile(rest, (frames, 1, 1, 1))
    for j in range(skeleton.num_joints):
        turn = Slerp(keys, Rotation.from_rotvec(vectors[:, j]))(times).as_matrix()
        local[:, j, :3, :3] = rest[j, :3, :3] @ turn
    return skinning_matrices(skeleton, global_transforms(skeleton, local))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--vertices", type=int, default=50_000)
    parser.add_argument("--frames", type=int, default=120)
    args = parser.parse_args()
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        vertices, faces, skeleton, weights = pool.submit(skinned_creature, args.vertices).result()
    mats = clip(skeleton, args.frames, np.random.default_rng(0))
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024
    started = time.perf_counter()
    out = relax_weights(vertices, faces, weights, mats)
    seconds = time.perf_counter() - started
    row = {"vertices": len(vertices), "joints": skeleton.num_joints, "frames": len(mats), "seconds": round(seconds, 3),
           **out.figures(), "rss_before_mib": before,
           "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024,
           "target_s": TARGET_S, "ok": seconds <= TARGET_S}
    table = Table(title=f"Weight relaxation under a clip ({platform.processor() or platform.machine()})")
    for key in row:
        table.add_column(key, justify="right")
    table.add_row(*[str(v) for v in row.values()])
    Console(width=200).print(table)
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps({"rows": [row]}, indent=1))


if __name__ == "__main__":
    main()
