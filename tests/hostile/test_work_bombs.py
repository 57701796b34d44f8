"""Work bombs through the stages they target: refused with too_large, fast and in bounded memory."""

from __future__ import annotations

import time
import tracemalloc

import numpy as np
import pytest

from simcore.budgets import Budgets
from simcore.errors import SimcoreError
from simcore.geometry.voxelize import solid_voxels
from simcore.options import JobOptions
from simcore.pipeline import PipelineInputs, _stages, run_pipeline
from tests.hostile.bomb_cases import huge_triangles_glb


def run_skeleton(tmp_path, data: bytes, budgets: Budgets | None = None) -> tuple[BaseException | None, float, int]:
    """(the error or None, seconds, peak bytes traced) of ingest + skeleton on the file."""
    (tmp_path / "bomb.glb").write_bytes(data)
    _stages()  # the stage modules' imports are not the bomb's cost
    tracemalloc.start()
    started = time.monotonic()
    error: BaseException | None = None
    try:
        run_pipeline(PipelineInputs(tmp_path / "bomb.glb", "glb"), JobOptions(stages=["skeleton"]), tmp_path / "out", budgets=budgets)
    except SimcoreError as exc:
        error = exc
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return error, time.monotonic() - started, peak


def test_thousands_of_huge_triangles_fail_with_too_large_quickly_and_in_bounded_memory(tmp_path):
    error, seconds, peak = run_skeleton(tmp_path, huge_triangles_glb(2_000))
    assert getattr(error, "code", None) == "too_large" and getattr(error, "field", None) == "mesh", error
    assert "RIGFORGE_BUDGETS__SURFACE_SAMPLES" in str(error)
    assert seconds < 10 and peak < 200 * 2**20, (seconds, peak)


def test_a_few_huge_triangles_voxelise_within_the_default_budget_at_a_fine_resolution():
    corners = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 0], [2, 0, 2], [0, 2, 2]], float)
    started = time.monotonic()
    grid = solid_voxels(corners, np.arange(6).reshape(2, 3), resolution=128)
    assert time.monotonic() - started < 5 and grid.surface.sum() > 128 * 128 // 2


@pytest.mark.parametrize("limit", [1_000])
def test_the_sample_budget_is_a_setting(tmp_path, limit):
    error, _, _ = run_skeleton(tmp_path, huge_triangles_glb(2), Budgets(surface_samples=limit))
    assert getattr(error, "code", None) == "too_large" and f"{limit:,}" in str(error), error
