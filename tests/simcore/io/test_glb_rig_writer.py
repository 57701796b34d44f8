"""rigged.glb: the original mesh kept, a skin that the Khronos validator accepts, and three readers agree."""

from __future__ import annotations

import io

import numpy as np
import pygltflib
import pytest
import scipy.sparse as sp
import trimesh
from scipy.spatial.transform import Rotation

from simcore.errors import InvalidInput
from simcore.io.glb_rig_writer import write_rigged_glb
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import read_rigged_asset
from simcore.io.gltf_validate import validate_gltf_file
from simcore.skeleton.kinematics import bind_matrices
from simcore.skeleton.types import Skeleton
from tests.simcore.io.rig_export_fixtures import capsule_glb, chain_skeleton, falloff_weights


@pytest.fixture(scope="module")
def capsule():
    return capsule_glb()


@pytest.fixture(scope="module")
def rigged(capsule, tmp_path_factory):
    glb, mesh = capsule
    skeleton = chain_skeleton(3)
    weights = falloff_weights(mesh.vertices, skeleton, keep=3)
    path = tmp_path_factory.mktemp("glb") / "rigged.glb"
    export = write_rigged_glb(glb, skeleton, weights, out_path=path)
    return skeleton, weights, export, path


def test_rigged_glb_passes_khronos_validator(rigged):
    result = validate_gltf_file(rigged[3])
    assert result.errors == 0, result.messages
    assert result.warnings == 0, result.messages


def test_original_mesh_data_is_kept(capsule, rigged):
    before, after = GltfDocument.from_bytes(capsule[0]), GltfDocument.from_bytes(rigged[2].data)
    attrs_before = before.json["meshes"][0]["primitives"][0]
    attrs_after = after.json["meshes"][0]["primitives"][0]
    for key in ("POSITION", "NORMAL", "TEXCOORD_0"):
        np.testing.assert_array_equal(before.accessor(attrs_before["attributes"][key]),
                                      after.accessor(attrs_after["attributes"][key]))
    np.testing.assert_array_equal(before.accessor(attrs_before["indices"]), after.accessor(attrs_after["indices"]))
    assert after.json["materials"] == before.json["materials"]
    img_view = lambda doc: doc.items("bufferViews")[doc.json["images"][0]["bufferView"]]  # noqa: E731
    v0, v1 = img_view(before), img_view(after)
    png = lambda doc, v: doc.buffers[0][v["byteOffset"]:v["byteOffset"] + v["byteLength"]]  # noqa: E731
    assert png(before, v0) == png(after, v1)


def test_own_reader_recovers_skeleton_and_weights(rigged):
    skeleton, weights, export, _ = rigged
    asset = read_rigged_asset(GltfDocument.from_bytes(export.data))
    assert asset.skeleton.names == skeleton.names
    np.testing.assert_array_equal(asset.skeleton.parents, skeleton.parents)
    np.testing.assert_allclose(asset.skeleton.positions, skeleton.positions, atol=1e-6)
    np.testing.assert_allclose(asset.weights.toarray(), weights.toarray(), atol=1e-6)


def test_pygltflib_and_trimesh_see_the_same_rig(rigged):
    skeleton, weights, export, _ = rigged
    doc = pygltflib.GLTF2.load_from_bytes(export.data)  # our own output: trusted bytes
    assert len(doc.skins) == 1 and len(doc.skins[0].joints) == skeleton.num_joints
    assert [doc.nodes[n].name for n in doc.skins[0].joints] == skeleton.names
    assert doc.accessors[doc.meshes[0].primitives[0].attributes.POSITION].count == weights.shape[0]
    scene = trimesh.load(io.BytesIO(export.data), file_type="glb", process=False, force="scene")
    assert isinstance(scene, trimesh.Scene)
    assert sum(len(g.vertices) for g in scene.geometry.values()) == weights.shape[0]


def test_eight_influences_write_two_joint_sets(capsule, tmp_path):
    glb, mesh = capsule
    skeleton = chain_skeleton(10)
    weights = falloff_weights(mesh.vertices, skeleton, keep=8, width=0.3)
    path = tmp_path / "rigged8.glb"
    export = write_rigged_glb(glb, skeleton, weights, max_influences=8, out_path=path)
    attrs = GltfDocument.from_bytes(export.data).json["meshes"][0]["primitives"][0]["attributes"]
    assert {"JOINTS_0", "WEIGHTS_0", "JOINTS_1", "WEIGHTS_1"} <= set(attrs)
    assert validate_gltf_file(path).errors == 0
    asset = read_rigged_asset(GltfDocument.from_bytes(export.data))
    np.testing.assert_allclose(asset.weights.toarray(), weights.toarray(), atol=1e-6)


def test_four_influences_truncate_and_renormalise(capsule):
    glb, mesh = capsule
    skeleton = chain_skeleton(10)
    weights = falloff_weights(mesh.vertices, skeleton, keep=8, width=0.3)
    export = write_rigged_glb(glb, skeleton, weights, max_influences=4)
    got = read_rigged_asset(GltfDocument.from_bytes(export.data)).weights.toarray()
    assert (np.count_nonzero(got, axis=1) <= 4).all()
    np.testing.assert_allclose(got.sum(axis=1), 1.0, atol=1e-6)
    assert export.stats["influences"]["truncated_vertices"] > 0


def test_over_256_joints_use_unsigned_short_indices(capsule, tmp_path):
    glb, mesh = capsule
    skeleton = chain_skeleton(300)
    path = tmp_path / "many.glb"
    export = write_rigged_glb(glb, skeleton, falloff_weights(mesh.vertices, skeleton, keep=4, width=0.01), out_path=path)
    doc = GltfDocument.from_bytes(export.data)
    joints_acc = doc.json["meshes"][0]["primitives"][0]["attributes"]["JOINTS_0"]
    assert doc.json["accessors"][joints_acc]["componentType"] == 5123
    assert validate_gltf_file(path).errors == 0


def test_oriented_joints_keep_their_bind_frames(capsule, tmp_path):
    glb, mesh = capsule
    base = chain_skeleton(3)
    orient = Rotation.from_euler("xyz", [[0, 0, 90], [30, 0, 0], [0, 45, 10]], degrees=True).as_quat()
    skeleton = Skeleton(base.positions, base.parents, base.names, orientations=orient)
    path = tmp_path / "oriented.glb"
    export = write_rigged_glb(glb, skeleton, falloff_weights(mesh.vertices, skeleton, keep=3), out_path=path)
    asset = read_rigged_asset(GltfDocument.from_bytes(export.data))
    np.testing.assert_allclose(asset.bind_matrices, bind_matrices(skeleton), atol=1e-6)
    doc = GltfDocument.from_bytes(export.data)  # node TRS must compose to the same bind frames
    world = doc.world_matrices()[np.asarray(doc.json["skins"][0]["joints"])]
    np.testing.assert_allclose(world, bind_matrices(skeleton), atol=1e-6)
    assert validate_gltf_file(path).errors == 0


def test_unweighted_vertices_bind_to_nearest_joint(capsule):
    glb, mesh = capsule
    skeleton = chain_skeleton(3)
    weights = falloff_weights(mesh.vertices, skeleton, keep=3).tolil()
    top = int(np.argmax(mesh.vertices[:, 1]))
    weights[top, :] = 0
    export = write_rigged_glb(glb, skeleton, weights.tocsr())
    got = read_rigged_asset(GltfDocument.from_bytes(export.data)).weights.toarray()
    assert got[top, 2] == pytest.approx(1.0)
    assert export.stats["influences"]["unweighted_vertices_bound_to_nearest_joint"] == 1


def test_weight_rows_must_match_mesh_vertices(capsule):
    glb, mesh = capsule
    skeleton = chain_skeleton(3)
    with pytest.raises(InvalidInput) as err:
        write_rigged_glb(glb, skeleton, sp.csr_matrix((len(mesh.vertices) - 1, 3)))
    assert err.value.code == "export_shape_mismatch"


def test_transformed_mesh_node_is_refused(capsule):
    mesh = capsule[1]
    scene = trimesh.Scene()
    scene.add_geometry(mesh, transform=trimesh.transformations.translation_matrix([1, 0, 0]))
    glb = trimesh.exchange.gltf.export_glb(scene)
    skeleton = chain_skeleton(3)
    with pytest.raises(InvalidInput) as err:
        write_rigged_glb(glb, skeleton, falloff_weights(mesh.vertices, skeleton, keep=3))
    assert err.value.code == "export_mesh_layout"
