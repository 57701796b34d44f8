import numpy as np
import pytest

from simcore.errors import Canceled
from simcore.geometry.mesh import IngestedMesh
from simcore.options import JobOptions, RefineOptions
from simcore.pipeline import PipelineInputs, PipelineState, StageProgress


def _refine(capsule, opts, **rig):
    from simcore.mpm.refine import refine_character

    vertices, faces, skeleton, weights, animation = capsule(**rig)
    return vertices, refine_character(vertices, faces, skeleton, weights, animation, opts)


def test_static_skeleton_keeps_the_rest_shape(capsule):
    vertices, result = _refine(capsule, RefineOptions(enabled=True, grid=32, preroll_frames=1), frames=4)
    assert result.frames.shape == (4, len(vertices), 3) and result.frames.dtype == np.float32
    assert np.abs(result.frames - vertices[None]).max() < 1e-3
    assert max(result.report["mean_abs_det_f_minus_1"]) < 1e-3


@pytest.mark.slow
def test_static_skeleton_keeps_the_rest_shape_for_100_frames(capsule):
    vertices, result = _refine(capsule, RefineOptions(enabled=True, grid=48, preroll_frames=0), frames=100)
    assert np.abs(result.frames - vertices[None]).max() < 1e-3


def test_violent_drive_never_produces_nan(capsule):
    opts = RefineOptions(enabled=True, grid=32, preroll_frames=0, substeps=20, preset="stiff")
    vertices, result = _refine(capsule, opts, bend_degrees=720.0, frames=4, root_speed=20.0)
    assert np.all(np.isfinite(result.frames))
    assert result.report["clamped"]["non_finite_vertices_replaced_by_lbs"] == 0
    # the CFL bounds, not the requested 20 substeps, set the step for this motion
    assert result.report["substeps_per_frame"] > 20


def test_refine_stage_sets_frames_and_reports_volume(capsule, tmp_path):
    from simcore.mpm import refine_stage

    vertices, faces, skeleton, weights, animation = capsule(bend_degrees=90.0, frames=6)
    options = JobOptions(refine=RefineOptions(enabled=True, grid=32, preroll_frames=1))
    state = PipelineState(PipelineInputs(tmp_path / "in.glb", "glb"), options, tmp_path)
    state.mesh, state.skeleton, state.weights, state.animation = IngestedMesh(vertices, faces, b""), skeleton, weights, animation
    seen: list[float] = []
    refine_stage.run(state, StageProgress("refine", 0.0, 1.0, lambda name, f: seen.append(f), lambda: None))
    report = state.report["refine"]
    assert state.refined_frames is not None and state.refined_frames.shape == (6, len(vertices), 3)
    assert len(report["volume_ratio_lbs"]) == len(report["volume_ratio_refined"]) == 6
    # LBS collapses the bent joint; the simulated volume keeps more of it
    assert report["max_volume_change_refined"] < report["max_volume_change_lbs"]
    assert 0 < report["max_displacement_from_lbs_m"] < 0.2
    assert seen == sorted(seen) and seen[-1] == pytest.approx(1.0)


def test_refine_stage_honours_cancel_between_frames(capsule, tmp_path):
    from simcore.mpm import refine_stage

    vertices, faces, skeleton, weights, animation = capsule(bend_degrees=30.0, frames=5)
    state = PipelineState(PipelineInputs(tmp_path / "in.glb", "glb"),
                          JobOptions(refine=RefineOptions(enabled=True, grid=32, preroll_frames=0, substeps=10)), tmp_path)
    state.mesh, state.skeleton, state.weights, state.animation = IngestedMesh(vertices, faces, b""), skeleton, weights, animation
    calls = []

    def cancel() -> None:
        calls.append(1)
        if len(calls) > 2:
            raise Canceled("canceled")

    with pytest.raises(Canceled):
        refine_stage.run(state, StageProgress("refine", 0.0, 1.0, lambda name, f: None, cancel))
    assert state.refined_frames is None


def test_refine_stage_skips_without_animation(capsule, tmp_path):
    from simcore.mpm import refine_stage

    state = PipelineState(PipelineInputs(tmp_path / "in.glb", "glb"), JobOptions(refine=RefineOptions(enabled=True)), tmp_path)
    refine_stage.run(state, StageProgress("refine", 0.0, 1.0, lambda name, f: None, lambda: None))
    assert "skipped" in state.report["refine"] and state.report["warnings"]
