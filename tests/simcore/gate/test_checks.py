"""The quality gate on a 1 m capsule rig: each check passes the sound rig and flags its broken case; a figure
past a hard threshold fails the stage unless options.quality_gate is "warn"."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from simcore.errors import SimcoreError
from simcore.gate.checks import QualityGateFailed, check_stage
from simcore.geometry.mesh import IngestedMesh
from simcore.options import JobOptions
from simcore.pipeline import PipelineInputs, PipelineState
from tests.simcore.mpm.conftest import capsule_rig


def rig_state(tmp_path, gate: str = "fail", bend: float = 30.0, frames: int = 6) -> PipelineState:
    vertices, faces, skeleton, weights, animation = capsule_rig(bend_degrees=bend, frames=frames)
    state = PipelineState(PipelineInputs(tmp_path / "in.glb", "glb"), JobOptions(quality_gate=gate), tmp_path)
    state.mesh, state.skeleton, state.weights, state.animation = IngestedMesh(vertices, faces, b""), skeleton, weights, animation
    return state


def run_checks(state: PipelineState, *stages: str) -> dict[str, dict]:
    """Check each stage as the pipeline does; returns the warnings by code."""
    for stage in stages:
        state.stage = stage
        check_stage(stage, state)
    return {w["code"]: w for w in state.report.get("warnings", [])}


def test_sound_rig_and_bend_pass_every_check(tmp_path):
    state = rig_state(tmp_path)
    assert run_checks(state, "skeleton", "skin", "motion") == {}
    motion = state.report["quality"]["motion"]
    assert motion["frames"] == 6 and motion["stretch_low"] < 1.0 < motion["stretch_high"]  # it did bend


def _with_weights(state: PipelineState, edit) -> PipelineState:  # noqa: ANN001 - edit: (V, J) array → None
    assert state.weights is not None
    w = state.weights.toarray()
    edit(w)
    state.weights = sp.csr_matrix(w)
    return state


def zero_row(w: np.ndarray) -> None:
    w[5] = 0.0


def test_unweighted_vertex_fails_the_skin_stage(tmp_path):
    with pytest.raises(QualityGateFailed) as err:
        run_checks(_with_weights(rig_state(tmp_path, "fail"), zero_row), "skin")
    assert err.value.code == "quality_gate" and "no skinning weight" in str(err.value)


def test_warn_mode_keeps_the_result_with_the_hard_warning(tmp_path):
    warning = run_checks(_with_weights(rig_state(tmp_path, "warn"), zero_row), "skin")["unweighted_vertices"]
    assert warning["hard"] and warning["figure"] == 1 and warning["stage"] == "skin" and warning["threshold"] == 0


def test_nan_and_unnormalised_weights_are_flagged(tmp_path):
    def scale_row(w: np.ndarray) -> None:
        w[3] *= 0.9

    def nan(w: np.ndarray) -> None:
        w[7, 0] = np.nan

    assert run_checks(_with_weights(rig_state(tmp_path, "warn"), scale_row), "skin")["weights_not_normalised"]["figure"] == pytest.approx(0.1)
    assert run_checks(_with_weights(rig_state(tmp_path, "warn"), nan), "skin")["non_finite_weights"]["hard"]


def test_joint_outside_and_zero_length_bone_warn_but_never_fail(tmp_path):
    state = rig_state(tmp_path, "fail")
    assert state.skeleton is not None
    state.skeleton.positions[2] = [0.0, 2.0, 0.0]  # the tip joint far above the capsule
    codes = run_checks(state, "skeleton")
    assert codes["joints_outside"]["figure"] == pytest.approx(2 / 3) and not codes["joints_outside"]["hard"]
    state = rig_state(tmp_path, "fail")
    assert state.skeleton is not None
    state.skeleton.positions[2] = state.skeleton.positions[1]
    assert run_checks(state, "skeleton")["zero_length_bones"]["figure"] == pytest.approx(0.5)


def test_a_collapse_in_one_frame_of_the_clip_fails_the_motion_stage(tmp_path):
    state = rig_state(tmp_path, "fail", bend=0.0, frames=7)
    assert state.animation is not None
    state.animation.translations[3, 1, 1] = 0.05  # frame 3 only: the upper half drops into the lower
    with pytest.raises(QualityGateFailed):
        run_checks(state, "motion")
    codes = {w["code"]: w for w in state.report["warnings"]}
    assert codes["volume_loss"]["frame"] == 3 and codes["volume_loss"]["hard"]
    assert state.report["quality"]["motion"]["stretch_low_frame"] == 3


def test_refinement_survives_a_driver_spike(tmp_path):
    from simcore.mpm import refine_stage
    from simcore.options import RefineOptions
    from simcore.pipeline import StageProgress

    def refine(spike: float) -> PipelineState:
        state = rig_state(tmp_path, "warn", bend=30.0)
        state.options = JobOptions(quality_gate="warn", refine=RefineOptions(enabled=True, grid=32, preroll_frames=1))
        assert state.animation is not None
        state.animation.translations[3, 0, 0] += spike  # the root jumps `spike` m for one frame (50 m/s at 2 m)
        state.stage = "refine"
        refine_stage.run(state, StageProgress("refine", 0.0, 1.0, lambda name, f: None, lambda: None))
        return state

    calm = refine(0.0)
    assert run_checks(calm, "refine") == {} and calm.report["quality"]["refine"]["tear_radii"] < 1.0
    spiked = refine(2.0)  # drivers are speed-limited and the tether holds the flesh near the skinned pose
    codes = run_checks(spiked, "refine")
    assert not [c for c in codes.values() if c["hard"]], codes
    assert spiked.report["refine"]["driver_steps_capped"] > 0
    assert spiked.report["quality"]["refine"]["offset_heights"] <= RefineOptions().max_offset * 1.05


def _refined_state(tmp_path, offset: float, volume_added: float) -> PipelineState:
    state = rig_state(tmp_path, "warn")
    assert state.mesh is not None and state.animation is not None
    state.animation.rotations[:] = [0, 0, 0, 1]
    state.refined_frames = np.stack([state.mesh.vertices.astype(np.float32)] * 6)
    state.refined_frames[3, 0, 0] += offset
    state.report["refine"] = {"clamped": {"non_finite_vertices_replaced_by_lbs": 0, "det_f": 0}, "particles": 100,
                              "substeps_run": 10, "max_volume_change_added": volume_added,
                              "max_displacement_from_lbs_heights": offset}
    return state


def test_refinement_offset_and_volume_past_their_bounds_fail(tmp_path):
    assert run_checks(_refined_state(tmp_path, 0.01, 0.0), "refine") == {}
    codes = run_checks(_refined_state(tmp_path, 0.3, 0.05), "refine")
    assert codes["refine_offset"]["hard"] and codes["refine_volume"]["hard"]
    state = _refined_state(tmp_path, 0.3, 0.0)
    state.options = JobOptions(quality_gate="fail")
    with pytest.raises(QualityGateFailed):
        check_stage("refine", state)


def test_refinement_nan_is_a_hard_failure(tmp_path):
    state = rig_state(tmp_path, "warn")
    assert state.mesh is not None and state.animation is not None
    state.refined_frames = np.stack([state.mesh.vertices.astype(np.float32)] * 6)
    state.report["refine"] = {"clamped": {"non_finite_vertices_replaced_by_lbs": 4, "det_f": 0}, "particles": 100, "substeps_run": 10}
    state.animation.rotations[:] = [0, 0, 0, 1]
    codes = run_checks(state, "refine")
    assert codes["refine_non_finite"]["hard"] and codes["refine_non_finite"]["figure"] == 4


def test_a_stage_error_carries_the_warnings_recorded_before_it(tmp_path):
    from simcore.pipeline import run_pipeline

    obj = tmp_path / "tri.obj"
    obj.write_text("v 0 0 0\nv 150 0 0\nv 0 150 0\nf 1 2 3\n")  # 150 units: read as centimetres, with a notice
    with pytest.raises(SimcoreError) as err:  # an OBJ has no skin to keep
        run_pipeline(PipelineInputs(obj, "obj"), JobOptions(skeleton="keep"), tmp_path / "work")
    assert err.value.code == "no_skeleton"
    assert [(w["stage"], w["code"]) for w in err.value.warnings] == [("ingest", "notice")]
