"""read_rigged_asset on files that bind their meshes with several skins: the rig is the union of every skin's
joints in one bind space, one tree, weights on the merged joints, and the rest pose is reproduced exactly."""

from __future__ import annotations

import base64
import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from simcore.errors import InvalidInput
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import read_rigged_asset, rig_rest_matrices, used_joints
from simcore.io.gltf_static import bake_static_glb


@dataclass
class _Node:
    name: str
    translation: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotation: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
    children: list[int] = field(default_factory=list)


@dataclass
class _SkinnedMesh:
    skin: int
    vertices: np.ndarray  # (V, 3) in that skin's bind space
    joints: np.ndarray  # (V, 4) slots of that skin's joints
    weights: np.ndarray  # (V, 4)


def _trs(node: _Node) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = Rotation.from_quat(node.rotation).as_matrix()
    m[:3, 3] = node.translation
    return m


def _worlds(nodes: list[_Node]) -> np.ndarray:
    """(N, 4, 4) rest world matrices of a node forest."""
    parent = {c: p for p, n in enumerate(nodes) for c in n.children}
    out = np.zeros((len(nodes), 4, 4))
    for i in range(len(nodes)):
        chain, k = [], i
        while k >= 0:
            chain.append(k)
            k = parent.get(k, -1)
        m = np.eye(4)
        for k in reversed(chain):
            m = m @ _trs(nodes[k])
        out[i] = m
    return out


def _gltf(nodes: list[_Node], skins: list[tuple[list[int], np.ndarray]], meshes: list[_SkinnedMesh]) -> bytes:
    """A glTF (JSON with an embedded buffer): `nodes` (joints), one node per skinned mesh, `skins` as (joint
    nodes, (J, 4, 4) bind matrices, i.e. inverse of the inverse bind matrices)."""
    blobs: list[bytes] = []
    accessors: list[dict[str, Any]] = []

    def add(array: np.ndarray, kind: str, component: int) -> int:
        blobs.append(array.tobytes())
        accessors.append({"bufferView": len(blobs) - 1, "componentType": component, "count": len(array), "type": kind})
        if kind == "VEC3":
            accessors[-1] |= {"min": array.min(0).tolist(), "max": array.max(0).tolist()}
        return len(accessors) - 1

    gl_nodes: list[dict[str, Any]] = [{"name": n.name, "translation": list(n.translation), "rotation": list(n.rotation),
                                       "children": list(n.children)} for n in nodes]
    gl_skins = []
    for joints, bind in skins:
        ibm = np.linalg.inv(bind).transpose(0, 2, 1).astype(np.float32)  # column-major
        gl_skins.append({"joints": joints, "inverseBindMatrices": add(ibm.reshape(-1, 16), "MAT4", 5126)})
    gl_meshes = []
    for k, m in enumerate(meshes):
        attrs = {"POSITION": add(m.vertices.astype(np.float32), "VEC3", 5126),
                 "JOINTS_0": add(m.joints.astype(np.uint16), "VEC4", 5123),
                 "WEIGHTS_0": add(m.weights.astype(np.float32), "VEC4", 5126)}
        tris = np.array([[i, i + 1, i + 2] for i in range(0, len(m.vertices) - 2, 3)], np.uint16).reshape(-1)
        gl_meshes.append({"primitives": [{"attributes": attrs, "indices": add(tris, "SCALAR", 5123)}]})
        gl_nodes.append({"name": f"mesh{k}", "mesh": k, "skin": m.skin})
    child = {c for n in nodes for c in n.children}
    roots = [i for i in range(len(nodes)) if i not in child] + list(range(len(nodes), len(gl_nodes)))
    offsets = np.cumsum([0] + [len(b) for b in blobs])
    doc = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": roots}], "nodes": gl_nodes,
        "skins": gl_skins, "meshes": gl_meshes, "accessors": accessors,
        "bufferViews": [{"buffer": 0, "byteOffset": int(offsets[k]), "byteLength": len(b)} for k, b in enumerate(blobs)],
        "buffers": [{"byteLength": int(offsets[-1]),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(b"".join(blobs)).decode()}],
    }
    return json.dumps(doc).encode()


def _one_joint(slot: int, count: int) -> tuple[np.ndarray, np.ndarray]:
    joints = np.zeros((count, 4), np.int64)
    joints[:, 0] = slot
    weights = np.zeros((count, 4))
    weights[:, 0] = 1.0
    return joints, weights


def _blob(centre: np.ndarray, count: int, seed: int) -> np.ndarray:
    """`count` points (a multiple of 3: triangles) spread about `centre` in 3D."""
    return centre + np.random.default_rng(seed).uniform(-0.2, 0.2, (count, 3))


def _in(space: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ space[:3, :3].T + space[:3, 3]


SPACE = np.eye(4)  # a second skin's own bind space: rotated, scaled and moved against the first's
SPACE[:3, :3] = 2.0 * Rotation.from_euler("xyz", [20, -40, 75], degrees=True).as_matrix()
SPACE[:3, 3] = [5.0, -3.0, 1.0]


def _shared_joints_file(posed: bool = False) -> tuple[bytes, np.ndarray, np.ndarray]:
    """hips → spine → head; skin 0 binds the body (hips, spine; 9 vertices), skin 1 the head mesh (spine,
    head; 6 vertices) in its own bind space SPACE. Returns (file, world bind vertices in file order, world
    bind joints by name order hips, spine, head)."""
    nodes = [_Node("hips", (0, 1, 0), children=[1]), _Node("spine", (0, 0.5, 0), children=[2]), _Node("head", (0, 0.5, 0))]
    bind_world = _worlds(nodes)
    if posed:  # the rest pose bends the spine: the inverse bind matrices still say where the bind pose was
        nodes[1].rotation = tuple(Rotation.from_euler("z", 40, degrees=True).as_quat())
    body = _blob(np.array([0, 1.2, 0]), 9, 0)
    head = _blob(np.array([0, 2.1, 0]), 6, 1)
    bj, bw = _one_joint(0, 9)
    bj[4:, 0], bj[4:, 1], bw[4:, :2] = 0, 1, 0.5  # some body vertices shared with spine
    hj, hw = _one_joint(1, 6)
    hj[:3, 0] = 0  # skin 1's slot 0 is spine
    skins = [([0, 1], bind_world[[0, 1]]), ([1, 2], SPACE @ bind_world[[1, 2]])]
    meshes = [_SkinnedMesh(0, body, bj, bw), _SkinnedMesh(1, _in(SPACE, head), hj, hw)]
    return _gltf(nodes, skins, meshes), np.concatenate([body, head]), bind_world[:, :3, 3]


def _two_characters_file() -> tuple[bytes, np.ndarray]:
    """A wolf (wolf → tail, 12 vertices) and its rider (rider → rider_head, 9 vertices, its own bind space
    local to the rider) that share no joint. Returns (file, world bind vertices in file order)."""
    turn = tuple(Rotation.from_euler("y", 70, degrees=True).as_quat())
    nodes = [_Node("wolf", (0, 0.6, 0), children=[1]), _Node("tail", (0, 0, -0.7)),
             _Node("rider", (0.1, 1.4, 0.2), turn, children=[3]), _Node("rider_head", (0, 0.5, 0))]
    world = _worlds(nodes)
    wolf = _blob(np.array([0, 0.6, -0.3]), 12, 2)
    rider = _blob(np.array([0.1, 1.7, 0.2]), 9, 3)
    rider_local = np.linalg.inv(world[2])  # the rider was modelled about its own root
    wj, ww = _one_joint(0, 12)
    wj[6:, 0] = 1
    rj, rw = _one_joint(1, 9)
    skins = [([0, 1], world[[0, 1]]), ([2, 3], rider_local @ world[[2, 3]])]
    meshes = [_SkinnedMesh(0, wolf, wj, ww), _SkinnedMesh(1, _in(rider_local, rider), rj, rw)]
    return _gltf(nodes, skins, meshes), np.concatenate([wolf, rider])


def test_shared_joints_are_one_joint_and_the_second_skin_joins_the_first_bind_space() -> None:
    data, bind_vertices, bind_joints = _shared_joints_file()
    asset = read_rigged_asset(GltfDocument.from_bytes(data))
    skeleton = asset.skeleton.validate()
    assert skeleton.names == ["hips", "spine", "head"] and skeleton.parents.tolist() == [-1, 0, 1]
    assert asset.skin_index == 0 and asset.skins == (0, 1)
    np.testing.assert_allclose(asset.vertices, bind_vertices, atol=1e-5)
    np.testing.assert_allclose(skeleton.positions, bind_joints, atol=1e-5)
    w = asset.weights.toarray()
    np.testing.assert_allclose(w.sum(axis=1), 1.0, atol=1e-6)
    np.testing.assert_allclose(w[9:12], [[0, 1, 0]] * 3)  # head mesh slot 0 = spine, the body's joint 1
    np.testing.assert_allclose(w[12:], [[0, 0, 1]] * 3)
    np.testing.assert_allclose(w[4:9], [[0.5, 0.5, 0]] * 5)


def test_rest_pose_of_every_skin_is_reproduced() -> None:
    data, _, _ = _shared_joints_file(posed=True)
    doc = GltfDocument.from_bytes(data)
    asset = read_rigged_asset(doc)
    mats = np.einsum("vj,jab->vab", asset.weights.toarray(), rig_rest_matrices(doc, asset))
    rest = np.einsum("vab,vb->va", mats[:, :3, :3], asset.vertices) + mats[:, :3, 3]
    np.testing.assert_allclose(rest, bake_static_glb(doc, np.eye(4))[1], atol=1e-5)


def test_skins_without_a_shared_joint_are_placed_where_the_scene_shows_them() -> None:
    data, bind_vertices = _two_characters_file()
    doc = GltfDocument.from_bytes(data)
    asset = read_rigged_asset(doc)
    skeleton = asset.skeleton.validate()
    assert sorted(skeleton.names) == ["rider", "rider_head", "tail", "wolf"]
    assert skeleton.names[0] == "wolf" and int((skeleton.parents < 0).sum()) == 1  # one tree, the bigger skin's root
    assert skeleton.parents[skeleton.names.index("rider")] == 0
    assert skeleton.parents[skeleton.names.index("rider_head")] == skeleton.names.index("rider")
    np.testing.assert_allclose(asset.vertices, bind_vertices, atol=1e-5)
    rider_head = skeleton.positions[skeleton.names.index("rider_head")]
    np.testing.assert_allclose(rider_head, _worlds([_Node("r", (0.1, 1.4, 0.2), children=[1]), _Node("h", (0, 0.5, 0))])[1, :3, 3],
                               atol=1e-5)
    assert used_joints(skeleton, asset.weights).all()
    w = asset.weights.toarray()
    head = skeleton.names.index("rider_head")
    assert w[12:, head].min() == 1.0 and w[:12, head].max() == 0.0


def test_a_skin_reached_only_through_another_skin_joins_by_its_shared_joint() -> None:
    """Three skins: 0 (hips, spine), 2 (head, hat: more vertices than 1) and 1 (spine, head). Skin 2 shares
    nothing with 0; it must join through skin 1's joints, not through a scene placement."""
    nodes = [_Node("hips", children=[1]), _Node("spine", (0, 0.5, 0), children=[2]), _Node("head", (0, 0.5, 0), children=[3]),
             _Node("hat", (0, 0.3, 0))]
    bind_world = _worlds(nodes)
    nodes[2].rotation = tuple(Rotation.from_euler("x", 50, degrees=True).as_quat())  # the rest pose bends the head
    other = np.linalg.inv(SPACE)
    parts = [(0, [0, 1], np.eye(4), 15), (1, [1, 2], SPACE, 6), (2, [2, 3], other, 9)]
    skins, meshes, expected = [], [], []
    for k, joints, space, count in parts:
        points = _blob(bind_world[joints[1], :3, 3], count, 10 + k)
        j, w = _one_joint(1, count)
        skins.append((joints, space @ bind_world[joints]))
        meshes.append(_SkinnedMesh(k, _in(space, points), j, w))
        expected.append(points)
    asset = read_rigged_asset(GltfDocument.from_bytes(_gltf(nodes, skins, meshes)))
    assert asset.skins == (0, 2, 1)  # by vertices covered
    assert asset.skeleton.names == ["hips", "spine", "head", "hat"]
    np.testing.assert_allclose(asset.vertices, np.concatenate(expected), atol=1e-5)
    np.testing.assert_allclose(asset.skeleton.positions, bind_world[:, :3, 3], atol=1e-5)


def test_a_second_skin_with_out_of_range_joint_indices_is_refused() -> None:
    doc = json.loads(_two_characters_file()[0])
    doc["skins"][1]["joints"] = doc["skins"][1]["joints"][:1]
    doc["accessors"][doc["skins"][1]["inverseBindMatrices"]]["count"] = 1
    with pytest.raises(InvalidInput, match="beyond the skin's joints"):
        read_rigged_asset(GltfDocument.from_bytes(json.dumps(doc).encode()))


def test_job_ingest_weights_every_vertex_of_every_skin() -> None:
    from simcore.ingest import ingest

    data, bind_vertices = _two_characters_file()
    mesh = ingest(data, "gltf")
    assert mesh.source_rig is not None
    assert mesh.source_rig.skeleton.num_joints == 4
    sums = np.asarray(mesh.source_rig.weights.sum(axis=1)).ravel()
    np.testing.assert_allclose(sums, 1.0, atol=1e-5)


def test_skeleton_eval_ground_truth_holds_every_skin(tmp_path) -> None:
    from simcore.evaluation.skeleton_eval import load_case

    path = tmp_path / "wolf_and_rider.gltf"
    path.write_bytes(_two_characters_file()[0])
    case = load_case(path)
    assert sorted(case.gt.names) == ["rider", "rider_head", "tail", "wolf"]
