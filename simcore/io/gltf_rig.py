"""Rigged-asset extraction from a GltfDocument: bind-pose mesh, skin skeleton and per-vertex weights.

Conventions follow the glTF skinning model: vertices are the skinned primitives' POSITION in mesh
space (meshes parented under a joint are moved there and follow that joint), joint bind positions are the translations of inverse(inverseBindMatrix). Joint parents are the
nearest ancestor node that is also a joint of the same skin.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from simcore.errors import InvalidInput
from simcore.io.gltf_document import GltfDocument
from simcore.skeleton.types import Skeleton

MODES_TRIANGLES = 4
MODES_TRIANGLE_STRIP = 5
MODES_TRIANGLE_FAN = 6
TRIANGLE_MODES = (MODES_TRIANGLES, MODES_TRIANGLE_STRIP, MODES_TRIANGLE_FAN)


@dataclass
class RiggedAsset:
    """A skinned mesh at bind pose.

    vertices: (V, 3) float64 bind-space positions of the rig's skinned primitives and of the meshes rigidly
              parented under its joints, concatenated in node order.
    faces:    (F, 3) int64 triangles indexing `vertices`.
    skeleton: the skin's joints (bind positions, parents, node names).
    weights:  (V, J) float32 CSR matrix, rows normalised to 1 where any weight exists.
    joint_nodes: (J,) glTF node index of each joint.
    bind_matrices: (J, 4, 4) float64 inverse of each inverse bind matrix (joint's bind transform).
    """

    vertices: np.ndarray
    faces: np.ndarray
    skeleton: Skeleton
    weights: sp.csr_matrix
    joint_nodes: np.ndarray
    bind_matrices: np.ndarray


def primitive_triangles(doc: GltfDocument, prim: dict, vertex_count: int) -> np.ndarray:
    """(F, 3) int64 triangles of a primitive (indexed or not): triangle lists, strips and fans (strips keep a
    consistent winding, degenerate triangles are dropped); points and lines give (0, 3)."""
    mode = prim.get("mode", MODES_TRIANGLES)
    if mode not in TRIANGLE_MODES:
        return np.zeros((0, 3), np.int64)
    if "indices" in prim:
        idx = doc.accessor(prim["indices"]).reshape(-1).astype(np.int64)
    else:
        idx = np.arange(vertex_count, dtype=np.int64)
    if len(idx) and (idx.min() < 0 or idx.max() >= vertex_count):
        raise InvalidInput("triangle index out of range", code="invalid_gltf", field="mesh")
    if mode == MODES_TRIANGLES:
        if len(idx) % 3:
            raise InvalidInput("triangle index count is not a multiple of 3", code="invalid_gltf", field="mesh")
        return idx.reshape(-1, 3)
    k = np.arange(max(len(idx) - 2, 0))
    if mode == MODES_TRIANGLE_STRIP:  # glTF 2.0 §3.7.2.1: odd triangles swap their first two vertices
        odd = k % 2 == 1
        tri = np.stack([idx[k], np.where(odd, idx[k + 2], idx[k + 1]), np.where(odd, idx[k + 1], idx[k + 2])], axis=1)
    else:  # fan around the first vertex
        tri = np.stack([np.full(len(k), idx[0] if len(idx) else 0), idx[k + 1], idx[k + 2]], axis=1)
    keep = (tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 0] != tri[:, 2])
    return tri[keep].reshape(-1, 3)


def _skin_skeleton(doc: GltfDocument, skin_index: int) -> tuple[Skeleton, np.ndarray, np.ndarray]:
    skin = doc.items("skins")[skin_index]
    joints = np.asarray(skin.get("joints", []), dtype=np.int64)
    if len(joints) == 0:
        raise InvalidInput("skin has no joints", code="invalid_gltf", field="mesh")
    if "inverseBindMatrices" in skin:
        ibm = doc.accessor(skin["inverseBindMatrices"]).astype(np.float64).reshape(-1, 4, 4).transpose(0, 2, 1)
        if len(ibm) != len(joints):
            raise InvalidInput("inverseBindMatrices count differs from joints", code="invalid_gltf", field="mesh")
        bind = np.linalg.inv(ibm)
    else:
        bind = doc.world_matrices()[joints]
    node_parents = doc.node_parents()
    slot = {int(n): k for k, n in enumerate(joints)}
    parents = []
    for n in joints:
        p = int(node_parents[n])
        while p >= 0 and p not in slot:
            p = int(node_parents[p])
        parents.append(slot[p] if p >= 0 else -1)
    nodes = doc.items("nodes")
    names = [str(nodes[n].get("name") or f"joint{k}") for k, n in enumerate(joints)]
    names = _unique(names)
    skeleton = Skeleton(bind[:, :3, 3], np.asarray(parents), names)
    if len(np.flatnonzero(skeleton.parents < 0)) > 1:
        skeleton = _join_roots(skeleton)
    return skeleton, joints, bind


def _unique(names: list[str]) -> list[str]:
    seen: dict[str, int] = {}
    out = []
    for n in names:
        k = seen.get(n, 0)
        seen[n] = k + 1
        out.append(n if k == 0 else f"{n}.{k}")
    return out


def _join_roots(skeleton: Skeleton) -> Skeleton:
    """Several skin roots: keep them as a forest under the first root (glTF allows forests, our tree does not)."""
    parents = skeleton.parents.copy()
    roots = np.flatnonzero(parents < 0)
    parents[roots[1:]] = roots[0]
    return Skeleton(skeleton.positions, parents, skeleton.names, skeleton.kinds)


def _chosen_skin(doc: GltfDocument, skinned: list[dict]) -> int:
    """The skin whose meshes hold the most vertices."""
    counts: dict[int, int] = {}
    for n in skinned:
        for prim in doc.items("meshes")[n["mesh"]].get("primitives", []):
            if "JOINTS_0" in prim.get("attributes", {}):
                counts[n["skin"]] = counts.get(n["skin"], 0) + doc.items("accessors")[prim["attributes"]["POSITION"]]["count"]
    if not counts:
        raise InvalidInput("skinned meshes carry no JOINTS_0", code="no_skin", field="mesh")
    return max(counts, key=counts.get)


def _same_rig(doc: GltfDocument, a: int, b: int) -> bool:
    """Whether skins a and b bind the same joints with the same bind matrices (one armature, several meshes)."""
    skins = doc.items("skins")
    if a == b:
        return True
    if skins[a].get("joints") != skins[b].get("joints"):
        return False
    ibm = [skins[k].get("inverseBindMatrices") for k in (a, b)]
    if ibm[0] is None or ibm[1] is None:
        return ibm[0] == ibm[1]
    return bool(np.allclose(doc.accessor(ibm[0]), doc.accessor(ibm[1]), atol=1e-6))


def _skinned_part(doc: GltfDocument, prim: dict, j: int) -> tuple[np.ndarray, sp.coo_matrix] | None:
    """(bind-space vertices, (V, J) weights) of one skinned primitive; None when it has no skin attributes."""
    attrs = prim.get("attributes", {})
    if "POSITION" not in attrs or "JOINTS_0" not in attrs:
        return None
    v = doc.accessor(attrs["POSITION"]).astype(np.float64)
    rows, cols, vals = [], [], []
    s = 0
    while f"JOINTS_{s}" in attrs and f"WEIGHTS_{s}" in attrs:
        ji = doc.accessor(attrs[f"JOINTS_{s}"]).astype(np.int64)
        wi = doc.accessor(attrs[f"WEIGHTS_{s}"]).astype(np.float64)
        if ji.shape != (len(v), 4) or wi.shape != (len(v), 4):
            raise InvalidInput("JOINTS/WEIGHTS must be VEC4 per vertex", code="invalid_gltf", field="mesh")
        if ji.size and ji.max() >= j:
            raise InvalidInput("JOINTS_n index beyond the skin's joints", code="invalid_gltf", field="mesh")
        keep = wi > 0
        rows.append(np.broadcast_to(np.arange(len(v))[:, None], ji.shape)[keep])
        cols.append(ji[keep])
        vals.append(wi[keep])
        s += 1
    return v, sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(len(v), j))


def _rigid_joint(doc: GltfDocument, node: int, joints: np.ndarray) -> int | None:
    """Slot of the joint that carries an unskinned mesh node (itself or its nearest joint ancestor), if any."""
    slot = {int(n): k for k, n in enumerate(joints)}
    parents = doc.node_parents()
    while node >= 0 and node not in slot:
        node = int(parents[node])
    return slot.get(node)


def read_rigged_asset(doc: GltfDocument) -> RiggedAsset:
    """Extract the rig whose skin covers most vertices; raise InvalidInput when the file has no skinned mesh.

    Every mesh bound to that armature counts: skinned meshes of any skin with the same joints and bind
    matrices, and unskinned meshes parented under one of its joints (a robot's rigid parts), which follow
    that joint with weight 1 and are moved into bind space (bind @ inverse(joint's rest world) @ node world).
    """
    nodes = doc.items("nodes")
    meshes = doc.items("meshes")
    skinned = [n for n in nodes if "skin" in n and "mesh" in n]
    if not skinned:
        raise InvalidInput("the file has no skinned mesh", code="no_skin", field="mesh")
    skin_index = _chosen_skin(doc, skinned)
    skeleton, joints, bind = _skin_skeleton(doc, skin_index)
    j = skeleton.num_joints
    world = doc.world_matrices()
    verts, faces, weights = [], [], []
    for index, node in enumerate(nodes):
        if "mesh" not in node:
            continue
        if "skin" in node:
            if not _same_rig(doc, skin_index, int(node["skin"])):
                continue
            parts = [(prim, _skinned_part(doc, prim, j)) for prim in meshes[node["mesh"]].get("primitives", [])]
        else:
            slot = _rigid_joint(doc, index, joints)
            if slot is None:
                continue
            to_bind = bind[slot] @ np.linalg.inv(world[joints[slot]]) @ world[index]
            parts = []
            for prim in meshes[node["mesh"]].get("primitives", []):
                if "POSITION" not in prim.get("attributes", {}):
                    continue
                v = doc.accessor(prim["attributes"]["POSITION"]).astype(np.float64)
                w = sp.coo_matrix((np.ones(len(v)), (np.arange(len(v)), np.full(len(v), slot))), shape=(len(v), j))
                parts.append((prim, (v @ to_bind[:3, :3].T + to_bind[:3, 3], w)))
        for prim, part in parts:
            if part is None:
                continue
            offset = sum(len(v) for v in verts)
            faces.append(primitive_triangles(doc, prim, len(part[0])) + offset)
            verts.append(part[0])
            weights.append(part[1])
    vertices = np.concatenate(verts)
    w = sp.vstack(weights).tocsr()
    sums = np.asarray(w.sum(axis=1)).ravel()
    w = sp.diags(np.where(sums > 0, 1.0 / np.maximum(sums, 1e-12), 0.0)) @ w
    return RiggedAsset(vertices, np.concatenate(faces), skeleton, w.astype(np.float32).tocsr(), joints, bind)


def used_joints(skeleton: Skeleton, weights: sp.csr_matrix, eps: float = 1e-6) -> np.ndarray:
    """(J,) bool: joints that influence a vertex or have a descendant that does."""
    keep = np.asarray(weights.max(axis=0).todense()).ravel() > eps
    for jnt in np.flatnonzero(keep):
        p = skeleton.parents[jnt]
        while p >= 0 and not keep[p]:
            keep[p] = True
            p = skeleton.parents[p]
    return keep
