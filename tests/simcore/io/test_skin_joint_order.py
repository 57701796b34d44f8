"""Studio rigs whose skin lists joints in any order, with a second root (a prop bone): read as one parents-first
tree, rigged in keep mode, and written back with the upload's joint order, hierarchy and motion (issue 25)."""

from __future__ import annotations

import numpy as np
import pytest

from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import read_rigged_asset
from simcore.io.usd_validate import validate_usd_file
from simcore.motion.gltf_clips import sample_node_worlds
from simcore.options import JobOptions
from simcore.pipeline import PipelineInputs, run_pipeline
from tests.simcore.io.studio_rig_fixtures import studio_rig, to_glb

UNORDERED = ["spine", "head", "hips"]  # the root is not first
TWO_ROOTS = ["sword", "head", "spine", "hips"]  # the prop root first, children before parents


def _skin_layout(doc: GltfDocument) -> tuple[list[str], list[str | None]]:
    """(skin joint names in skin order, each one's parent node name or None at a scene root)."""
    nodes, parents = doc.items("nodes"), doc.node_parents()
    joints = doc.items("skins")[0]["joints"]
    return [nodes[j]["name"] for j in joints], [nodes[parents[j]]["name"] if parents[j] >= 0 else None for j in joints]


@pytest.mark.parametrize("order", [UNORDERED, TWO_ROOTS], ids=["unordered", "two-roots"])
def test_any_skin_order_reads_as_one_parents_first_tree(order):
    asset = read_rigged_asset(GltfDocument.from_bytes(to_glb(studio_rig(order))))
    skeleton = asset.skeleton.validate()
    assert skeleton.names[0] == "hips" and skeleton.parents[0] == -1
    assert skeleton.file_order is not None and skeleton.file_parents is not None
    assert [order[k] for k in skeleton.file_order] == skeleton.names
    heaviest = np.asarray(asset.weights.sum(axis=0)).ravel()
    assert skeleton.names[int(np.argmax(heaviest))] in ("spine", "hips")  # columns follow the joints they weigh
    if "sword" in order:
        sword = skeleton.names.index("sword")
        assert skeleton.file_parents[sword] == -1 and skeleton.parents[sword] == 0
        blade = asset.vertices[:, 0] > 0.3
        assert np.allclose(asset.weights[blade][:, sword].toarray(), 1.0)


@pytest.mark.parametrize("order", [UNORDERED, TWO_ROOTS], ids=["unordered", "two-roots"])
def test_keep_mode_writes_the_upload_joint_order_roots_and_motion_back(tmp_path, order):
    source = to_glb(studio_rig(order, animated=True))
    (tmp_path / "rig.glb").write_bytes(source)
    inputs = PipelineInputs(tmp_path / "rig.glb", "glb", tmp_path / "rig.glb", "glb")
    state = run_pipeline(inputs, JobOptions(skeleton="keep"), tmp_path / "out")
    src = GltfDocument.from_bytes(source)
    for name in ("rigged.glb", "animated.glb"):
        out = GltfDocument.from_bytes(state.artifacts[name].read_bytes())
        assert _skin_layout(out) == _skin_layout(src)
    times = np.array([0.0, 0.25, 0.5, 0.8])
    expected = sample_node_worlds(src, 0, times, np.asarray(src.items("skins")[0]["joints"]))
    got = sample_node_worlds(out, 0, times, np.asarray(out.items("skins")[0]["joints"]))
    np.testing.assert_allclose(got, expected, atol=1e-5)  # every joint, the swinging sword included


@pytest.mark.parametrize("order", [UNORDERED, TWO_ROOTS], ids=["unordered", "two-roots"])
def test_auto_mode_rigs_a_studio_file_with_any_skin_order(tmp_path, order):
    (tmp_path / "rig.glb").write_bytes(to_glb(studio_rig(order)))
    state = run_pipeline(PipelineInputs(tmp_path / "rig.glb", "glb"), JobOptions(), tmp_path / "out")
    assert {"rigged.glb", "rigged.usdc"} <= set(state.artifacts)


def test_keep_mode_usd_keeps_the_upload_roots_and_plays_its_motion(tmp_path):
    """UsdSkel wants parents before children but allows several roots: the prop root stays a root, and every
    joint's world track matches the upload's clip."""
    from pxr import Usd, UsdGeom, UsdSkel

    source = to_glb(studio_rig(TWO_ROOTS, animated=True))
    (tmp_path / "rig.glb").write_bytes(source)
    inputs = PipelineInputs(tmp_path / "rig.glb", "glb", tmp_path / "rig.glb", "glb")
    state = run_pipeline(inputs, JobOptions(skeleton="keep"), tmp_path / "out")
    assert validate_usd_file(state.artifacts["animated.usdc"]).ok
    stage = Usd.Stage.Open(str(state.artifacts["animated.usdc"]))
    skel = UsdSkel.Skeleton(stage.GetPrimAtPath("/Character/Skeleton"))
    paths = [str(p) for p in skel.GetJointsAttr().Get()]
    assert "sword" in paths and "hips" in paths  # two roots, as uploaded
    names = [str(n) for n in skel.GetJointNamesAttr().Get()]
    query = UsdSkel.Cache().GetSkelQuery(skel)
    fps = stage.GetTimeCodesPerSecond()
    src = GltfDocument.from_bytes(source)
    skin_names, _ = _skin_layout(src)
    frames = np.array([0, 3, 6, 9])
    expected = sample_node_worlds(src, 0, frames / fps, np.asarray(src.items("skins")[0]["joints"]))
    for k, frame in enumerate(frames):
        worlds = query.ComputeJointWorldTransforms(UsdGeom.XformCache(float(frame)))
        got = np.array([np.array(worlds[names.index(n)]).T[:3, 3] for n in skin_names])
        np.testing.assert_allclose(got, expected[k][:, :3, 3], atol=1e-4)
