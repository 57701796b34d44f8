"""The `too_large` pre-check: estimate a stage's peak memory from the job's sizes and refuse it before it runs.

The estimate is linear in what drives each stage's memory: vertices for skeleton, skinning and export (the
models and grids are a fixed part; skinning runs on a bounded proxy above a size, so the rest is per-vertex
arrays), vertex-frames for physics refinement (its float32 positions are held by the stage, the gate and the
morph-target export, with room for their temporaries). The mesh coefficients are peak bytes above the process's
resting size as `bench/job_memory.py` measures them, rounded up.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from simcore.budgets import MIB, current, process_memory_cap
from simcore.errors import LimitExceeded

if TYPE_CHECKING:
    from simcore.pipeline import PipelineState

FIXED_BYTES = 768 * MIB  # skeleton, skin and export: models, voxel grids and proxy, whatever the mesh size
BYTES_PER_VERTEX = 1024  # skeleton, skin and export, per mesh vertex
BYTES_PER_VERTEX_FRAME = 64  # physics refinement, per mesh vertex and output frame
MESH_STAGES = ("skeleton", "skin", "export")


def data_segment_bytes() -> int:
    """This process's data segment now (VmData): what the memory cap counts."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmData:"):
                return int(line.split()[1]) * 1024
    return 0


def stage_estimate(stage: str, state: PipelineState) -> tuple[int, str, str] | None:
    """(estimated peak bytes, what it is from, the field to blame) of `stage`, or None when it needs little."""
    if state.mesh is None:
        return None
    vertices = len(state.mesh.vertices)
    if stage in MESH_STAGES:
        return FIXED_BYTES + BYTES_PER_VERTEX * vertices, f"the mesh has {vertices:,} vertices", "mesh"
    if stage == "refine" and state.options.refine.enabled and state.animation is not None:
        frames = state.animation.num_frames
        return (BYTES_PER_VERTEX_FRAME * vertices * frames,
                f"refining {frames:,} frames of a {vertices:,}-vertex mesh", "motion")
    return None


def check_fits(stage: str, state: PipelineState) -> None:
    """Raise LimitExceeded (too_large) when `stage` cannot fit the memory the worker process has left."""
    estimate = stage_estimate(stage, state)
    if estimate is None:
        return
    need, what, field = estimate
    cap = process_memory_cap()
    source = "the worker's memory cap"
    if cap is None:
        cap, source = current().memory_cap_bytes(), "the memory budget"
    left = cap - data_segment_bytes()
    if need > left:
        raise LimitExceeded(
            f"{what}: the {stage} stage would need about {need / MIB:,.0f} MB, more than the {max(left, 0) / MIB:,.0f} MB "
            f"left of {source} ({cap / MIB:,.0f} MB, RIGFORGE_BUDGETS__WORKER_MEMORY_MB)",
            code="too_large", field=field)
