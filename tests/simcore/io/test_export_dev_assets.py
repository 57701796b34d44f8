"""A real character: the fox's own skeleton and weights re-exported onto a static copy of its mesh."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from simcore.io.glb_rig_writer import write_rigged_glb
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import read_rigged_asset
from simcore.io.gltf_validate import validate_gltf_file
from simcore.io.usd_skel_writer import write_usd_skel
from simcore.io.usd_validate import validate_usd_file
from simcore.skeleton.types import Skeleton


@pytest.fixture(scope="module")
def fox(dev_assets):
    data = (dev_assets / "fox.glb").read_bytes()
    asset = read_rigged_asset(GltfDocument.from_bytes(data))
    scene = trimesh.load(dev_assets / "fox.glb", process=False, force="scene")
    assert isinstance(scene, trimesh.Scene)
    geometry = list(scene.geometry.values())
    static = trimesh.exchange.gltf.export_glb(trimesh.Scene(geometry), include_normals=True)  # the ingest contract
    orient = Rotation.from_matrix(asset.bind_matrices[:, :3, :3]).as_quat()
    skeleton = Skeleton(asset.skeleton.positions, asset.skeleton.parents, asset.skeleton.names, orientations=orient)
    return static, skeleton, asset


def test_fox_rigged_glb_validates_and_round_trips(fox, tmp_path):
    static, skeleton, asset = fox
    path = tmp_path / "fox_rigged.glb"
    export = write_rigged_glb(static, skeleton, asset.weights, out_path=path)
    result = validate_gltf_file(path)
    assert result.errors == 0, result.messages
    back = read_rigged_asset(GltfDocument.from_bytes(export.data))
    assert back.skeleton.names == skeleton.names
    np.testing.assert_allclose(back.skeleton.positions, skeleton.positions, atol=1e-4)
    np.testing.assert_allclose(back.weights.toarray(), asset.weights.toarray(), atol=1e-6)
    doc = GltfDocument.from_bytes(export.data)
    assert doc.json.get("images") and doc.json.get("materials")  # texture carried over


def test_fox_usd_passes_compliance(fox, tmp_path):
    static, skeleton, asset = fox
    for path in write_usd_skel(static, skeleton, asset.weights, tmp_path / "fox.usdc", usdz_path=tmp_path / "fox.usdz")[:2]:
        result = validate_usd_file(path)
        assert result.ok, result.errors
