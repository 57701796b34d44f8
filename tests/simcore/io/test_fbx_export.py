"""rigged.fbx / animated.fbx written by Blender's exporter, read back by an independent reader (assimp): same
bones, bind positions, skin weights (max difference <= 1e-3) and posed vertices (<= 1e-3 of the size) as the GLB."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from scipy.spatial import cKDTree

from simcore.io.fbx_export import blender_python, write_fbx
from simcore.io.glb_rig_writer import write_rigged_glb
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import read_rigged_asset
from simcore.motion.fbx_convert import assimp_binary, fbx_to_glb
from simcore.motion.gltf_clips import sample_node_worlds
from simcore.skinning.lbs import linear_blend
from tests.simcore.io.rig_export_fixtures import bend_animation, capsule_glb, chain_skeleton, falloff_weights

pytestmark = [
    pytest.mark.skipif(blender_python() is None, reason="FBX writer not installed: no bpy (`make fbx-writer` "
                                                        "or RIGFORGE_BLENDER_PYTHON)"),
    pytest.mark.skipif(assimp_binary() is None, reason="no independent FBX reader: apt-get install assimp-utils"),
]
CM = 0.01  # the FBX scene is in centimetres (UnitScaleFactor 1), as Unity and Unreal expect


def _mesh_to_world(doc: GltfDocument) -> np.ndarray:
    """(4, 4) world matrix of the skinned mesh node, in metres: assimp puts the FBX's axis and unit conversion
    there (Blender's Z-up metres → the file's Y-up centimetres); skinning leaves it out, as glTF says."""
    node = next(i for i, n in enumerate(doc.items("nodes")) if "skin" in n)
    return doc.world_matrices()[node] * np.array([[CM], [CM], [CM], [1.0]])


def _apply(m: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ m[:3, :3].T + m[:3, 3]


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("fbx")
    glb, mesh = capsule_glb()
    skeleton = chain_skeleton(4)
    weights = falloff_weights(mesh.vertices, skeleton, keep=3)
    animation = bend_animation(skeleton, frames=12, fps=24.0)
    out = {}
    plans: list[tuple[str, dict[str, Any]]] = [("rigged", {}), ("animated", {"animation": animation})]
    for name, extra in plans:
        write_rigged_glb(glb, skeleton, weights, out_path=tmp / f"{name}.glb", **extra)
        write_fbx(tmp / f"{name}.glb", tmp / f"{name}.fbx", fps=animation.fps)
        out[name] = (GltfDocument.from_bytes((tmp / f"{name}.glb").read_bytes()),
                     GltfDocument.from_bytes(fbx_to_glb((tmp / f"{name}.fbx").read_bytes(), field="fbx")))
    return out, animation, float(np.ptp(mesh.vertices, axis=0).max())


def _posed(doc: GltfDocument, seconds: float, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """(bind, posed) world vertices of `doc`'s rig at `seconds` into its first clip, times `scale`."""
    asset = read_rigged_asset(doc)
    worlds = sample_node_worlds(doc, 0, np.array([seconds]), asset.joint_nodes)
    posed = linear_blend(asset.vertices, asset.weights, worlds @ np.linalg.inv(asset.bind_matrices))[0]
    return _apply(_mesh_to_world(doc), asset.vertices) if scale != 1 else asset.vertices, posed * scale


def _matches(ours: np.ndarray, theirs: np.ndarray, size: float) -> list[np.ndarray]:
    """For each of their vertices, our vertices at the same place (FBX splits and merges vertices differently)."""
    near = cKDTree(ours).query_ball_point(theirs, r=1e-4 * size)
    assert all(len(n) for n in near), "an FBX vertex lies where the GLB has none"
    return [np.asarray(n) for n in near]


@pytest.mark.parametrize("name", ["rigged", "animated"])
def test_fbx_has_the_same_bones_bind_pose_and_weights(exported, name):
    files, _, size = exported
    glb, fbx = (read_rigged_asset(doc) for doc in files[name])
    to_world = _mesh_to_world(files[name][1])
    assert sorted(fbx.skeleton.names) == sorted(glb.skeleton.names)
    order = [fbx.skeleton.names.index(n) for n in glb.skeleton.names]
    bind = _apply(to_world, fbx.bind_matrices[order, :3, 3])
    assert np.abs(bind - glb.skeleton.positions).max() <= 1e-4 * size
    matches = _matches(glb.vertices, _apply(to_world, fbx.vertices), size)
    ours, theirs = glb.weights.toarray(), fbx.weights.toarray()[:, order]
    worst = max(np.abs(ours[m] - theirs[i]).max(axis=1).min() for i, m in enumerate(matches))
    assert worst <= 1e-3, worst
    assert len(matches) >= 0.5 * len(glb.vertices)


def test_animated_fbx_poses_like_the_glb(exported):
    files, animation, size = exported
    for frame in (animation.num_frames // 2, animation.num_frames - 1):
        seconds = frame / animation.fps
        ours_bind, ours = _posed(files["animated"][0], seconds, 1.0)
        theirs_bind, theirs = _posed(files["animated"][1], seconds, CM)
        matches = _matches(ours_bind, theirs_bind, size)
        worst = max(np.linalg.norm(ours[m] - theirs[i], axis=1).min() for i, m in enumerate(matches))
        assert worst <= 1e-3 * size, (frame, worst / size)


def test_fbx_keeps_the_material_and_embeds_its_texture(exported):
    files, _, _ = exported
    for glb, fbx in files.values():
        assert len(fbx.items("materials")) == len(glb.items("materials")) == 1
        (image,) = fbx.items("images")
        data = fbx.view_bytes(image["bufferView"])[0] if "bufferView" in image else b""
        assert data.startswith(b"\x89PNG"), image
        factor = fbx.items("materials")[0]["pbrMetallicRoughness"]["baseColorFactor"]
        expected = glb.items("materials")[0]["pbrMetallicRoughness"]["baseColorFactor"]
        np.testing.assert_allclose(factor[:3], expected[:3], atol=2e-3)
