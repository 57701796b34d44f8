"""The `motion` pipeline stage: BVH and glTF uploads, clips inside the mesh upload, skipping, errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from simcore.errors import InvalidInput, UnsupportedFormat
from simcore.geometry.mesh import IngestedMesh
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import read_rigged_asset
from simcore.motion import fbx_convert, stage
from simcore.options import JobOptions
from simcore.pipeline import PipelineInputs, PipelineState, StageProgress
from tests.simcore.motion.motion_samples import body_cloud, bvh_text, humanoid


def _state(tmp_path: Path, motion: Path | None = None, fmt: str | None = None, **motion_options) -> PipelineState:
    skel = humanoid()
    vertices, weights = body_cloud(skel)
    state = PipelineState(PipelineInputs(tmp_path / "in.glb", "glb", motion, fmt), JobOptions(motion=motion_options), tmp_path)
    soup = np.resize(np.arange(len(vertices)), (-(-len(vertices) // 3), 3))  # triangles over the cloud: every point is used
    state.mesh = IngestedMesh(vertices, soup, b"")
    state.skeleton, state.weights = skel, weights
    return state


def _progress(seen: list[float]) -> StageProgress:
    return StageProgress("motion", 0.5, 0.1, lambda name, f: seen.append(f), lambda: None)


def _walk_bvh(tmp_path: Path) -> Path:
    skel = humanoid(prefix="")
    t = np.arange(20)
    angles = np.zeros((20, skel.num_joints, 3))
    for side, sign in (("LeftUpLeg", 1), ("RightUpLeg", -1)):
        angles[:, skel.names.index(side), 1] = sign * 25 * np.sin(t / 3)  # ZXY: column 1 is X (swing)
    roots = np.stack([np.zeros(20), np.full(20, 1.0), t * 0.03], axis=1)
    path = tmp_path / "walk.bvh"
    path.write_text(bvh_text(skel, roots, angles, ["ZXY"] * skel.num_joints))
    return path


def test_bvh_upload_sets_animation_and_report(tmp_path):
    state = _state(tmp_path, _walk_bvh(tmp_path), "bvh", fps=10)
    seen: list[float] = []
    stage.run(state, _progress(seen))
    anim = state.animation
    assert anim is not None and state.skeleton is not None
    assert anim.joint_names == state.skeleton.names and anim.fps == 10
    assert anim.rotations.shape == (7, 22, 4) and np.all(np.isfinite(anim.translations))
    rep = state.report["motion"]
    assert rep["status"] == "retargeted" and rep["joint_map"]["mixamorig:LeftUpLeg"] == "LeftUpLeg"
    assert rep["clip"]["frames"] == 7 and rep["clip"]["source_frames"] == 20 and rep["unmapped_target_joints"] == []
    assert rep["foot_sliding"]["sliding_m_per_s"] >= 0 and 0 <= rep["self_penetration"]["penetration_fraction"] <= 1
    assert seen[-1] == pytest.approx(0.6)
    assert rep["clip"]["name"] == "walk"  # no uploaded name given: the file's own stem


def test_bvh_clip_is_named_after_the_uploaded_file_not_the_stored_one(tmp_path):
    stored = _walk_bvh(tmp_path).rename(tmp_path / "9f86d081884c7d65.bvh")  # storage names uploads by hash
    state = _state(tmp_path, stored, "bvh")
    state.inputs.motion_name = "studio_walk_v2"
    stage.run(state, _progress([]))
    assert state.report["motion"]["clip"]["name"] == "studio_walk_v2"


def test_no_motion_is_skipped_quietly(tmp_path):
    state = _state(tmp_path)
    stage.run(state, _progress([]))
    assert state.animation is None and state.report["motion"]["status"] == "none"


def test_bad_bvh_is_a_clear_error(tmp_path):
    path = tmp_path / "bad.bvh"
    path.write_text(_walk_bvh(tmp_path).read_text().replace("Frame Time:", "Frame Tme:"))
    with pytest.raises(InvalidInput) as err:
        stage.run(_state(tmp_path, path, "bvh"), _progress([]))
    assert err.value.code == "invalid_bvh" and err.value.field == "motion" and "line" in str(err.value)


def test_fbx_without_converter_is_unsupported(tmp_path, monkeypatch):
    monkeypatch.setattr(fbx_convert, "assimp_binary", lambda: None)
    path = tmp_path / "clip.fbx"
    path.write_bytes(b"Kaydara FBX Binary  \x00")
    with pytest.raises(UnsupportedFormat) as err:
        stage.run(_state(tmp_path, path, "fbx"), _progress([]))
    assert err.value.code == "unsupported_format" and err.value.field == "motion"


def test_clip_carried_by_the_mesh_upload(tmp_path, dev_assets):
    doc = GltfDocument.from_bytes((dev_assets / "fox.glb").read_bytes())
    asset = read_rigged_asset(doc)
    state = PipelineState(PipelineInputs(tmp_path / "fox.glb", "glb"), JobOptions(motion={"clip": "Walk"}), tmp_path)
    state.mesh = IngestedMesh(asset.vertices * 0.01, asset.faces, b"", 0.01, None, doc)  # ingest turned cm into m
    state.skeleton = read_rigged_asset(doc).skeleton
    state.skeleton.positions = state.skeleton.positions * 0.01
    state.weights = asset.weights
    stage.run(state, _progress([]))
    rep = state.report["motion"]
    assert rep["clip"]["name"] == "Walk" and rep["mapping_method"] == "names" and rep["unmapped_target_joints"] == []
    assert rep["root_scale"] == pytest.approx(0.01, rel=1e-3)
    with pytest.raises(InvalidInput) as err:
        stage.run(PipelineState(state.inputs, JobOptions(motion={"clip": 7}), tmp_path, mesh=state.mesh, skeleton=state.skeleton), _progress([]))
    assert err.value.code == "unknown_clip"


def test_clip_of_the_mesh_upload_on_an_auto_skeleton_shares_its_bind_pose(tmp_path, dev_assets):
    """A skeleton built on the ingested mesh plays the upload's own clip: the clip is moved into the mesh's frame
    and marked as sharing its bind pose, so root motion keeps its size (no hip-height rescaling)."""
    from dataclasses import replace

    from simcore.ingest import ingest
    from simcore.motion.retarget import retarget

    mesh = ingest((dev_assets / "fox.glb").read_bytes(), "glb")
    assert mesh.source_rig is not None
    state = PipelineState(PipelineInputs(tmp_path / "fox.glb", "glb"), JobOptions(motion={"clip": "Walk"}), tmp_path, mesh=mesh)
    clip = stage.clip_from_mesh_upload(state)
    assert clip.shares_bind_pose
    rig = mesh.source_rig.skeleton
    order = [rig.names.index(n) for n in clip.skeleton.names]
    assert np.allclose(clip.skeleton.positions, rig.positions[order], atol=1e-4)
    assert clip.bind_weights is not None  # the upload's skin, its columns in the clip's joint order
    assert np.array_equal(clip.bind_weights.toarray(), mesh.source_rig.weights.toarray()[:, order])
    low_hips = mesh.source_rig.skeleton  # a rig of the same body with the hips 10 % lower sets the root scale otherwise
    target = replace(low_hips, positions=low_hips.positions * [1.0, 0.9, 1.0])
    assert retarget(clip, target).root_scale == 1.0
    assert retarget(replace(clip, shares_bind_pose=False), target).root_scale == pytest.approx(0.9, rel=0.05)


def test_a_two_bone_uploads_clip_keeps_the_turn_of_its_joint_frames(tmp_path, dev_assets):
    """RiggedSimple's two joints lie on one line, which leaves a fit to their heads free to turn about it (a half
    turn made its bend go the other way): the clip's joint frames must land on the ingested rig's."""
    from scipy.spatial.transform import Rotation

    from simcore.ingest import ingest

    mesh = ingest((dev_assets / "rigged_simple.glb").read_bytes(), "glb")
    assert mesh.source_rig is not None
    state = PipelineState(PipelineInputs(tmp_path / "rigged_simple.glb", "glb"), JobOptions(motion={"clip": 0}), tmp_path, mesh=mesh)
    clip = stage.clip_from_mesh_upload(state)
    assert clip.shares_bind_pose and clip.skeleton.orientations is not None
    rig = mesh.source_rig.skeleton
    assert rig.orientations is not None
    order = [rig.names.index(n) for n in clip.skeleton.names]
    apart = Rotation.from_quat(clip.skeleton.orientations) * Rotation.from_quat(rig.orientations[order]).inv()
    assert np.degrees(apart.magnitude()).max() < 0.1


def test_the_clip_relaxes_the_weights_unless_asked_not_to(tmp_path):
    kept = _state(tmp_path, _walk_bvh(tmp_path), "bvh", fps=10, relax_weights=False)
    skin = kept.weights
    assert skin is not None
    shape = skin.shape
    stage.run(kept, _progress([]))
    assert kept.weights is skin and kept.report["motion"]["relaxation"] is None
    relaxed = _state(tmp_path, _walk_bvh(tmp_path), "bvh", fps=10)
    stage.run(relaxed, _progress([]))
    figures = relaxed.report["motion"]["relaxation"]
    assert set(figures) == {"vertices_moved", "edges_over", "mean_row_change", "tolerance"}
    out = relaxed.weights
    assert out is not None
    assert out.shape == shape
    np.testing.assert_allclose(np.asarray(out.sum(axis=1)).ravel(), 1.0, atol=1e-5)
