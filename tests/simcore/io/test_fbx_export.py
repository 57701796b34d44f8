"""rigged.fbx / animated.fbx written by Blender's exporter, read back by an independent reader (assimp): same
bones, bind positions, skin weights (max difference <= 1e-3) and posed vertices (<= 1e-3 of the size) as the GLB,
in the unit and axes each frame (default, the Unity and Unreal presets) asks for, with identity root nodes."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from simcore.io.fbx_export import PRESETS, FbxFrame, blender_python, fbx_frame, write_fbx
from simcore.io.glb_rig_writer import write_rigged_glb
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import RiggedAsset, read_rigged_asset
from simcore.motion.fbx_convert import assimp_binary
from simcore.motion.gltf_clips import sample_node_worlds
from simcore.options import FbxOptions
from simcore.skeleton.types import Skeleton
from simcore.skinning.lbs import linear_blend
from tests.simcore.io.rig_export_fixtures import bend_animation, capsule_glb, chain_skeleton, falloff_weights

pytestmark = [
    pytest.mark.skipif(blender_python() is None, reason="FBX writer not installed: no bpy (`make fbx-writer` "
                                                        "or RIGFORGE_BLENDER_PYTHON)"),
    pytest.mark.skipif(assimp_binary() is None, reason="no independent FBX reader: apt-get install assimp-utils"),
]
FRAMES = {"default": FbxFrame(), "unity": PRESETS["unity"], "unreal": PRESETS["unreal"]}
# glTF (Y up, facing +Z) → the file's axes: Y up keeps them; Z up (facing -Y) maps (x, y, z) to (x, -z, y)
AXES = {"y": np.eye(3), "z": np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])}
PER_METRE = {"m": 1.0, "cm": 100.0}


def _skeleton() -> Skeleton:
    """A chain up the capsule with a branch to its front (+Z) and side (+X), so a wrong axis can't pass."""
    chain = chain_skeleton(4)
    positions = np.vstack([chain.positions, [[0.06, 0.15, 0.08]]])
    return Skeleton(positions, np.append(chain.parents, 2), [*chain.names, "joint_front"])


def _assimp(fbx: Path, metres: bool) -> GltfDocument:
    """The FBX converted to glTF by assimp; with `metres`, assimp scales by the file's UnitScaleFactor."""
    out = fbx.with_name(f"{fbx.stem}-{'m' if metres else 'file'}.glb")
    command = [str(assimp_binary()), "export", str(fbx), str(out), "-f", "glb2", *(["--global-scale"] if metres else [])]
    subprocess.run(command, check=True, capture_output=True, timeout=60)
    return GltfDocument.from_bytes(out.read_bytes())


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """{(frame, name): (GLB doc, assimp doc in file units, assimp doc in metres)}, the clip and the mesh size."""
    tmp = tmp_path_factory.mktemp("fbx")
    glb, mesh = capsule_glb()
    skeleton = _skeleton()
    weights = falloff_weights(mesh.vertices, skeleton, keep=3)
    animation = bend_animation(skeleton, frames=12, fps=24.0)
    write_rigged_glb(glb, skeleton, weights, out_path=tmp / "rigged.glb")
    write_rigged_glb(glb, skeleton, weights, out_path=tmp / "animated.glb", animation=animation)
    plans = [("default", "rigged"), *((frame, "animated") for frame in FRAMES)]
    out = {}
    for frame, name in plans:
        fbx = tmp / f"{name}-{frame}.fbx"
        write_fbx(tmp / f"{name}.glb", fbx, fps=animation.fps, frame=FRAMES[frame])
        out[frame, name] = (GltfDocument.from_bytes((tmp / f"{name}.glb").read_bytes()), _assimp(fbx, False),
                            _assimp(fbx, True))
    return out, animation, float(np.ptp(mesh.vertices, axis=0).max())


def _to_file(frame: FbxFrame, points: np.ndarray, metres: bool = False) -> np.ndarray:
    """glTF points (metres, Y up) as the file stores them."""
    return points @ AXES[frame.up_axis].T * (1.0 if metres else PER_METRE[frame.units])


def _posed(doc: GltfDocument, asset: RiggedAsset, seconds: float) -> np.ndarray:
    """(V, 3) vertices of `doc`'s rig `seconds` into its first clip (linear blend skinning, as engines do)."""
    worlds = sample_node_worlds(doc, 0, np.array([seconds]), asset.joint_nodes)
    return linear_blend(asset.vertices, asset.weights, worlds @ np.linalg.inv(asset.bind_matrices))[0]


def _matches(ours: np.ndarray, theirs: np.ndarray, size: float) -> list[np.ndarray]:
    """For each of their vertices, our vertices at the same place (FBX splits and merges vertices differently)."""
    near = cKDTree(ours).query_ball_point(theirs, r=1e-4 * size)
    assert all(len(n) for n in near), "an FBX vertex lies where the GLB has none"
    return [np.asarray(n) for n in near]


def test_options_pick_the_frame():
    assert fbx_frame(False) is None and fbx_frame(True) == FbxFrame("cm", "y")
    assert fbx_frame(FbxOptions(preset="unity")) == FbxFrame("m", "y")
    assert fbx_frame(FbxOptions(preset="unreal")) == FbxFrame("cm", "z")
    assert fbx_frame(FbxOptions(preset="unreal", units="m")) == FbxFrame("m", "z")
    assert fbx_frame(FbxOptions(up_axis="z")) == FbxFrame("cm", "z")


@pytest.mark.parametrize("frame, name", [("default", "rigged"), *((f, "animated") for f in FRAMES)])
def test_fbx_has_the_same_bones_bind_pose_and_weights_in_its_unit_and_axes(exported, frame, name):
    files, _, size = exported
    glb_doc, file_doc, metre_doc = files[frame, name]
    glb, fbx, fbx_m = (read_rigged_asset(doc) for doc in (glb_doc, file_doc, metre_doc))
    skinned = next(i for i, n in enumerate(file_doc.items("nodes")) if "skin" in n)
    np.testing.assert_allclose(file_doc.world_matrices()[skinned], np.eye(4), atol=1e-6)  # no root turn or scale
    assert sorted(fbx.skeleton.names) == sorted(glb.skeleton.names)
    order = [fbx.skeleton.names.index(n) for n in glb.skeleton.names]
    expected = _to_file(FRAMES[frame], glb.skeleton.positions)
    scale = PER_METRE[FRAMES[frame].units]
    assert np.abs(fbx.bind_matrices[order, :3, 3] - expected).max() <= 1e-4 * size * scale
    expected_m = _to_file(FRAMES[frame], glb.skeleton.positions, metres=True)  # the file's UnitScaleFactor, read
    assert np.abs(fbx_m.bind_matrices[order, :3, 3] - expected_m).max() <= 1e-4 * size
    matches = _matches(_to_file(FRAMES[frame], glb.vertices), fbx.vertices, size * scale)
    ours, theirs = glb.weights.toarray(), fbx.weights.toarray()[:, order]
    worst = max(np.abs(ours[m] - theirs[i]).max(axis=1).min() for i, m in enumerate(matches))
    assert worst <= 1e-3, worst
    assert len(matches) >= 0.5 * len(glb.vertices)


@pytest.mark.parametrize("frame", list(FRAMES))
def test_animated_fbx_poses_like_the_glb(exported, frame):
    files, animation, size = exported
    glb_doc, _, metre_doc = files[frame, "animated"]
    glb, fbx = read_rigged_asset(glb_doc), read_rigged_asset(metre_doc)
    matches = _matches(_to_file(FRAMES[frame], glb.vertices, metres=True), fbx.vertices, size)
    for index in (animation.num_frames // 2, animation.num_frames - 1):
        seconds = index / animation.fps
        ours = _to_file(FRAMES[frame], _posed(glb_doc, glb, seconds), metres=True)
        theirs = _posed(metre_doc, fbx, seconds)
        worst = max(np.linalg.norm(ours[m] - theirs[i], axis=1).min() for i, m in enumerate(matches))
        assert worst <= 1e-3 * size, (index, worst / size)


@pytest.mark.parametrize("name", ["rigged", "animated"])
def test_fbx_keeps_the_material_and_embeds_its_texture(exported, name):
    files, _, _ = exported
    glb, fbx, _ = files["default", name]
    assert len(fbx.items("materials")) == len(glb.items("materials")) == 1
    (image,) = fbx.items("images")
    data = fbx.view_bytes(image["bufferView"])[0] if "bufferView" in image else b""
    assert data.startswith(b"\x89PNG"), image
    factor = fbx.items("materials")[0]["pbrMetallicRoughness"]["baseColorFactor"]
    expected = glb.items("materials")[0]["pbrMetallicRoughness"]["baseColorFactor"]
    np.testing.assert_allclose(factor[:3], expected[:3], atol=2e-3)
