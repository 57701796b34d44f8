"""animated.glb and refined.glb: joint channels and morph-target refinement that validate and replay exactly."""

from __future__ import annotations

import numpy as np
import pygltflib
import pytest

from simcore.io.glb_animation import morph_key_frames
from simcore.io.glb_rig_writer import write_rigged_glb
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_validate import validate_gltf_file
from simcore.io.joint_tracks import joint_tracks
from simcore.skinning.lbs import linear_blend
from tests.simcore.io.rig_export_fixtures import bend_animation, capsule_glb, chain_skeleton, falloff_weights


@pytest.fixture(scope="module")
def rig():
    glb, mesh = capsule_glb()
    skeleton = chain_skeleton(4)
    return glb, mesh, skeleton, falloff_weights(mesh.vertices, skeleton, keep=3), bend_animation(skeleton)


def _jiggle(mesh, skeleton, weights, animation) -> np.ndarray:
    """LBS of the clip plus a travelling radial wobble: a stand-in for the physics refinement output."""
    lbs = linear_blend(mesh.vertices, weights, joint_tracks(skeleton, animation).skin_matrices(skeleton))
    t = np.arange(len(lbs))[:, None, None]
    return lbs + 0.01 * np.sin(t + mesh.vertices[None, :, 1:2] * 20) * np.array([1.0, 0.0, 0.5])


def test_animated_glb_validates_and_carries_the_clip(rig, tmp_path):
    glb, mesh, skeleton, weights, animation = rig
    path = tmp_path / "animated.glb"
    export = write_rigged_glb(glb, skeleton, weights, animation=animation, out_path=path)
    result = validate_gltf_file(path)
    assert result.errors == 0 and result.warnings == 0, result.messages
    doc = GltfDocument.from_bytes(export.data)
    clip = doc.json["animations"][0]
    joint_nodes = doc.json["skins"][0]["joints"]
    paths = {(joint_nodes.index(c["target"]["node"]), c["target"]["path"]) for c in clip["channels"]}
    assert {(j, "rotation") for j in range(4)} <= paths and (0, "translation") in paths
    rot_channel = next(c for c in clip["channels"] if c["target"] == {"node": joint_nodes[2], "path": "rotation"})
    sampler = clip["samplers"][rot_channel["sampler"]]
    np.testing.assert_allclose(doc.accessor(sampler["input"])[:, 0], np.arange(12) / 24.0, atol=1e-6)
    np.testing.assert_allclose(doc.accessor(sampler["output"]), animation.rotations[:, 2], atol=1e-6)
    assert sampler["interpolation"] == "LINEAR"
    assert len(pygltflib.GLTF2.load_from_bytes(export.data).animations) == 1


def _shown(doc: GltfDocument, skeleton, animation, frame: int, key: int) -> np.ndarray:
    """Vertex positions a viewer shows at clip frame `frame`, which is morph key `key`: POSITION plus every
    target times its animated weight at that key, skinned with the stored influences."""
    prim = doc.json["meshes"][0]["primitives"][0]
    channel = next(c for c in doc.json["animations"][0]["channels"] if c["target"]["path"] == "weights")
    sampler = doc.json["animations"][0]["samplers"][channel["sampler"]]
    targets = prim["targets"]
    weights = doc.accessor(sampler["output"]).reshape(-1, len(targets))[key]
    morphed = doc.accessor(prim["attributes"]["POSITION"]).astype(np.float64)
    for w, target in zip(weights, targets):
        morphed += float(w) * doc.accessor(target["POSITION"])
    joints = doc.accessor(prim["attributes"]["JOINTS_0"]).astype(np.int64)
    w = doc.accessor(prim["attributes"]["WEIGHTS_0"]).astype(np.float64)
    blended = np.einsum("vk,vkab->vab", w, joint_tracks(skeleton, animation).skin_matrices(skeleton)[frame][joints])
    return np.einsum("vab,vb->va", blended[:, :3, :3], morphed) + blended[:, :3, 3]


def test_refined_glb_morph_targets_replay_the_simulated_frames(rig, tmp_path):
    glb, mesh, skeleton, weights, animation = rig
    refined = _jiggle(mesh, skeleton, weights, animation)
    path = tmp_path / "refined.glb"
    export = write_rigged_glb(glb, skeleton, weights, animation=animation, morph_frames=refined, out_path=path,
                              morph_tolerance=0.0)
    result = validate_gltf_file(path)
    assert result.errors == 0 and result.warnings == 0, result.messages
    doc = GltfDocument.from_bytes(export.data)
    assert "KHR_mesh_quantization" in doc.json["extensionsRequired"]
    assert export.stats["morph"]["keys"] == len(refined) == 12
    # A viewer morphs in bind space, then skins with the stored influences: that must give the simulation back.
    for t in (0, 5, 11):
        np.testing.assert_allclose(_shown(doc, skeleton, animation, t, t), refined[t], atol=2e-5)
    weights_channel = next(c for c in doc.json["animations"][0]["channels"] if c["target"]["path"] == "weights")
    assert doc.json["animations"][0]["samplers"][weights_channel["sampler"]]["interpolation"] == "STEP"


def test_compact_morphs_stay_within_the_tolerance_and_shrink(rig, tmp_path):
    glb, mesh, skeleton, weights, animation = rig
    refined = _jiggle(mesh, skeleton, weights, animation)
    path = tmp_path / "refined.glb"
    export = write_rigged_glb(glb, skeleton, weights, animation=animation, morph_frames=refined, out_path=path,
                              morph_tolerance=2e-3)
    assert validate_gltf_file(path).errors == 0
    stats = export.stats["morph"]
    size = float(np.ptp(mesh.vertices, axis=0).max())
    assert stats["tolerance"] == pytest.approx(2e-3 * size, rel=1e-6)
    assert stats["max_error"] <= 1.25 * stats["tolerance"]
    assert stats["basis_shapes"] > 0  # the wobble is a travelling wave: two shapes carry it
    assert stats["bytes"] < 0.5 * len(refined) * len(mesh.vertices) * 12  # well under float32 per frame
    doc = GltfDocument.from_bytes(export.data)
    for t in (3, 8):
        shown = _shown(doc, skeleton, animation, t, t)
        assert np.linalg.norm(shown - refined[t], axis=1).max() <= stats["max_error"] * 1.01 + 1e-5
    sparse = [doc.json["accessors"][tg["POSITION"]] for tg in doc.json["meshes"][0]["primitives"][0]["targets"]]
    assert all(a["componentType"] in (5120, 5122) and a["normalized"] for a in sparse)


def test_morph_keys_follow_the_simulation_rate():
    np.testing.assert_array_equal(morph_key_frames(12, 5), [0, 3, 6, 8, 11])
    keys = morph_key_frames(481, 256, fps=120.0, key_rate=30.0)
    assert len(keys) == 121 and np.all(np.diff(keys) == 4)
    assert len(morph_key_frames(12, 256, fps=24.0, key_rate=30.0)) == 12  # a clip slower than the rate: every frame


def test_long_refinement_keys_a_capped_subset_linearly(rig, tmp_path):
    glb, mesh, skeleton, weights, animation = rig
    path = tmp_path / "refined_sparse.glb"
    export = write_rigged_glb(glb, skeleton, weights, animation=animation, max_morph_targets=5,
                              morph_frames=_jiggle(mesh, skeleton, weights, animation), out_path=path)
    assert export.stats["morph"]["keys"] == 5 and export.stats["morph"]["interpolation"] == "LINEAR"
    assert export.stats["morph"]["targets"] <= 5
    assert validate_gltf_file(path).errors == 0


def test_refined_frames_need_an_animation(rig):
    glb, mesh, skeleton, weights, _ = rig
    with pytest.raises(Exception, match="animation"):
        write_rigged_glb(glb, skeleton, weights, morph_frames=np.zeros((2, len(mesh.vertices), 3)))


def test_refinement_equal_to_lbs_writes_no_targets(rig, tmp_path):
    glb, mesh, skeleton, weights, animation = rig
    lbs = linear_blend(mesh.vertices, weights, joint_tracks(skeleton, animation).skin_matrices(skeleton))
    path = tmp_path / "refined.glb"
    export = write_rigged_glb(glb, skeleton, weights, animation=animation, morph_frames=lbs, out_path=path)
    assert export.stats["morph"]["targets"] == 0
    assert validate_gltf_file(path).errors == 0
