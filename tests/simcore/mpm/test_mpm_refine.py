import numpy as np
import pytest

from simcore.errors import Canceled
from simcore.geometry.mesh import IngestedMesh
from simcore.options import JobOptions, RefineOptions
from simcore.pipeline import PipelineInputs, PipelineState, StageProgress
from tests.simcore.mpm.conftest import capsule_rig


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
    report = result.report
    # the CFL bounds, not the requested floor of 20 substeps per 25 fps frame, set the step for this motion
    assert report["dt_s"] < report["dt_limits_s"]["floor"]
    # the 20 m/s root is capped at the driver speed limit, and the tether bounds the offset from LBS
    assert report["driver_steps_capped"] > 0
    assert report["max_driver_speed_m_s"] <= report["driver_speed_limit_m_s"] * 1.02
    assert report["max_driver_speed_unlimited_m_s"] > report["driver_speed_limit_m_s"]
    assert report["max_displacement_from_lbs_heights"] <= opts.max_offset * 1.05
    assert report["estimate_estimate_s"] > 0 and report["estimate_substeps"] == report["substeps_run"]


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
    # figures at the simulated keys: 30 fps over the clip's 0.2 s
    assert len(report["volume_ratio_lbs"]) == len(report["volume_ratio_refined"]) == report["frames"] == 7
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


def test_keys_follow_the_rate_and_end_on_the_last_frame():
    from simcore.mpm.scene import key_times

    times = key_times(frames=121, fps=120.0, rate=30.0)  # 1 s of clip
    assert len(times) == 31 and times[-1] == pytest.approx(1.0)
    odd = key_times(frames=10, fps=120.0, rate=30.0)  # 0.075 s: keys at 0, 1/30, 2/30 and the end
    assert odd.tolist() == pytest.approx([0.0, 1 / 30, 2 / 30, 0.075])


def test_joints_are_speed_limited_and_catch_up():
    from simcore.mpm.drivers import driver_positions
    from simcore.mpm.scene import limit_world

    vertices, faces, skeleton, weights, animation = capsule_rig()
    from simcore.mpm.drivers import place_drivers

    drivers = place_drivers(skeleton, "joints", 0.05)
    times = np.arange(8) / 10.0
    world = np.tile(np.eye(4), (8, 3, 1, 1))
    world[:, :, :3, 3] = skeleton.positions
    world[3:, :, 0, 3] += 1.0  # every joint pops 1 m between keys 2 and 3, then stays
    out, capped = limit_world(world, drivers, times, limit=4.0)
    paths = driver_positions(drivers, out)
    speeds = np.linalg.norm(np.diff(paths, axis=0), axis=2) / 0.1
    assert speeds.max() <= 4.0 * 1.02 and capped > 0  # slerp: chord vs arc
    assert np.allclose(out[-1], world[-1])  # it catches up once the skeleton stops


def test_offsets_interpolate_between_keys():
    from simcore.mpm.refine import interpolate_offsets

    offsets = np.array([[[0.0, 0, 0]], [[1.0, 0, 0]]], np.float32)
    got = interpolate_offsets(offsets, np.array([0.0, 0.1]), np.array([0.0, 0.025, 0.1]))
    assert got[:, 0, 0].tolist() == pytest.approx([0.0, 0.25, 1.0])


def test_a_separate_piece_on_one_joint_stays_rigid_on_it(capsule):
    """A plate riding the tip joint alone keeps its LBS (rigid) motion while the bending capsule is simulated."""
    import scipy.sparse as sp
    import trimesh

    from simcore.mpm.refine import refine_character

    vertices, faces, skeleton, weights, animation = capsule(bend_degrees=90.0, frames=6)
    plate = trimesh.creation.box(extents=[0.1, 0.02, 0.1])
    plate_v = np.asarray(plate.vertices) + [0.0, 0.47, 0.0]
    all_v = np.vstack([vertices, plate_v])
    all_f = np.vstack([faces, np.asarray(plate.faces) + len(vertices)])
    plate_w = np.zeros((len(plate_v), 3))
    plate_w[:, 1] = 1.0
    all_w = sp.vstack([weights, sp.csr_matrix(plate_w)]).tocsr()
    opts = RefineOptions(enabled=True, grid=32, preroll_frames=1)
    result = refine_character(all_v, all_f, skeleton, all_w, animation, opts)
    from simcore.mpm.drivers import animation_world_transforms
    from simcore.skeleton.kinematics import skinning_matrices
    from simcore.skinning.lbs import linear_blend

    lbs = linear_blend(all_v, all_w, skinning_matrices(skeleton, animation_world_transforms(skeleton, animation)))
    assert result.report["rigid_piece_vertices"] == len(plate_v)
    plain = refine_character(vertices, faces, skeleton, weights, animation, opts)
    assert result.report["particles"] == plain.report["particles"]  # the plate takes none of the particle budget
    np.testing.assert_allclose(result.frames[:, len(vertices):], lbs[:, len(vertices):], atol=1e-5)
    assert np.abs(result.frames[:, :len(vertices)] - lbs[:, :len(vertices)]).max() > 1e-3  # the body is simulated


def test_refine_stage_skips_a_mesh_of_rigid_pieces_only(capsule, tmp_path):
    """Every piece bound to one joint alone (a segmented robot): nothing can deform, so nothing is simulated."""
    import scipy.sparse as sp

    from simcore.mpm import refine_stage

    vertices, faces, skeleton, _, animation = capsule(bend_degrees=60.0, frames=4)
    two = np.vstack([vertices, vertices + [0.5, 0.0, 0.0]])
    rows = np.zeros((len(two), 3))
    rows[: len(vertices), 0] = rows[len(vertices):, 1] = 1.0
    state = PipelineState(PipelineInputs(tmp_path / "in.glb", "glb"),
                          JobOptions(refine=RefineOptions(enabled=True, grid=32)), tmp_path)
    state.mesh = IngestedMesh(two, np.vstack([faces, faces + len(vertices)]), b"")
    state.skeleton, state.weights, state.animation = skeleton, sp.csr_matrix(rows), animation
    refine_stage.run(state, StageProgress("refine", 0.0, 1.0, lambda name, f: None, lambda: None))
    assert state.refined_frames is None
    assert state.report["refine"]["rigid_piece_vertices"] == len(two)
    assert any("nothing deforms" in w["message"] for w in state.report["warnings"])
