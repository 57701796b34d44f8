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


def test_refined_glb_morph_targets_replay_the_simulated_frames(rig, tmp_path):
    glb, mesh, skeleton, weights, animation = rig
    refined = _jiggle(mesh, skeleton, weights, animation)
    path = tmp_path / "refined.glb"
    export = write_rigged_glb(glb, skeleton, weights, animation=animation, morph_frames=refined, out_path=path)
    result = validate_gltf_file(path)
    assert result.errors == 0 and result.warnings == 0, result.messages
    doc = GltfDocument.from_bytes(export.data)
    prim = doc.json["meshes"][0]["primitives"][0]
    assert len(prim["targets"]) == len(refined) == len(doc.json["meshes"][0]["weights"])
    # A viewer morphs in bind space, then skins with the stored influences: that must give the simulation back.
    joints = doc.accessor(prim["attributes"]["JOINTS_0"]).astype(np.int64)
    w = doc.accessor(prim["attributes"]["WEIGHTS_0"]).astype(np.float64)
    skin = joint_tracks(skeleton, animation).skin_matrices(skeleton)
    for t in (0, 5, 11):
        morphed = doc.accessor(prim["attributes"]["POSITION"]) + doc.accessor(prim["targets"][t]["POSITION"])
        blended = np.einsum("vk,vkab->vab", w, skin[t][joints])
        shown = np.einsum("vab,vb->va", blended[:, :3, :3], morphed) + blended[:, :3, 3]
        np.testing.assert_allclose(shown, refined[t], atol=1e-5)
    weights_channel = next(c for c in doc.json["animations"][0]["channels"] if c["target"]["path"] == "weights")
    sampler = doc.json["animations"][0]["samplers"][weights_channel["sampler"]]
    assert sampler["interpolation"] == "STEP"
    np.testing.assert_array_equal(doc.accessor(sampler["output"]).reshape(12, 12), np.eye(12))


def test_long_refinement_keys_a_capped_subset_linearly(rig, tmp_path):
    glb, mesh, skeleton, weights, animation = rig
    path = tmp_path / "refined_sparse.glb"
    export = write_rigged_glb(glb, skeleton, weights, animation=animation, max_morph_targets=5,
                              morph_frames=_jiggle(mesh, skeleton, weights, animation), out_path=path)
    assert export.stats["morph"]["targets"] == 5 and export.stats["morph"]["interpolation"] == "LINEAR"
    assert validate_gltf_file(path).errors == 0
    np.testing.assert_array_equal(morph_key_frames(12, 5), [0, 3, 6, 8, 11])


def test_refined_frames_need_an_animation(rig):
    glb, mesh, skeleton, weights, _ = rig
    with pytest.raises(Exception, match="animation"):
        write_rigged_glb(glb, skeleton, weights, morph_frames=np.zeros((2, len(mesh.vertices), 3)))
