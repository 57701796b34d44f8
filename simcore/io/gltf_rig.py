"""Rigged-asset extraction from a GltfDocument: bind-pose mesh, skin skeleton and per-vertex weights.

Conventions follow the glTF skinning model: vertices are the skinned primitives' POSITION in mesh
space (meshes parented under a joint are moved there and follow that joint), joint bind positions are the
translations of inverse(inverseBindMatrix). Joint parents are the nearest ancestor node that is also a
joint of the same skin.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from simcore.errors import InvalidInput
from simcore.io.gltf_document import GltfDocument
from simcore.skeleton.types import Skeleton, parents_first_order

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
    skin_index: the glTF skin read.
    Joints are in the skeleton's order (parents first, one root); skeleton.file_order maps them to the skin's.
    """

    vertices: np.ndarray
    faces: np.ndarray
    skeleton: Skeleton
    weights: sp.csr_matrix
    joint_nodes: np.ndarray
    bind_matrices: np.ndarray
    skin_index: int = 0


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


def check_finite_weights(weights: np.ndarray, set_index: int) -> None:
    """Raise InvalidInput (code non_finite_weights) when a WEIGHTS_n accessor holds NaN or infinite values."""
    bad = ~np.isfinite(weights)
    if bad.any():
        raise InvalidInput(f"skin weights WEIGHTS_{set_index} hold {int(bad.any(axis=1).sum())} vertices with NaN or "
                           "infinite values", code="non_finite_weights", field="mesh")


def _skin_skeleton(doc: GltfDocument, skin_index: int) -> tuple[Skeleton, np.ndarray, np.ndarray]:
    """(skeleton in our layout, joint nodes and bind matrices in the skin's own `joints` order).

    glTF lets a skin list its joints in any order and have several roots; the skeleton is one tree with
    parents first: extra roots hang from the root with the most joints under it, and `file_order` /
    `file_parents` keep the upload's layout for export. skeleton.file_order[i] is joint i's skin slot.
    """
    skin = doc.items("skins")[skin_index]
    joints = np.asarray(skin.get("joints", []), dtype=np.int64)
    if len(joints) == 0:
        raise InvalidInput("skin has no joints", code="invalid_gltf", field="mesh")
    if "inverseBindMatrices" in skin:
        ibm = doc.accessor(skin["inverseBindMatrices"]).astype(np.float64).reshape(-1, 4, 4).transpose(0, 2, 1)
        if len(ibm) != len(joints):
            raise InvalidInput("inverseBindMatrices count differs from joints", code="invalid_gltf", field="mesh")
        if not np.all(np.isfinite(ibm)):
            raise InvalidInput("the skin's inverseBindMatrices hold NaN or infinite values", code="non_finite_bind", field="mesh")
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
    names = _unique([str(nodes[n].get("name") or f"joint{k}") for k, n in enumerate(joints)])
    file_parents = np.asarray(parents, dtype=np.int64)
    order = parents_first_order(_join_roots(file_parents))
    slot_skeleton = Skeleton(bind[:, :3, 3], _join_roots(file_parents), names, [], None, np.arange(len(joints)), file_parents)
    return slot_skeleton.reordered(order), joints, bind


def _unique(names: list[str]) -> list[str]:
    seen: dict[str, int] = {}
    out = []
    for n in names:
        k = seen.get(n, 0)
        seen[n] = k + 1
        out.append(n if k == 0 else f"{n}.{k}")
    return out


def _join_roots(parents: np.ndarray) -> np.ndarray:
    """Several skin roots (glTF allows a forest, our tree does not): the others hang from the root with the
    most joints under it (the body, not a prop bone beside it)."""
    roots = np.flatnonzero(parents < 0)
    if len(roots) < 2:
        return parents
    top = np.arange(len(parents))
    for _ in range(len(parents)):  # walk every joint up to its root
        top = np.where(parents[top] >= 0, parents[top], top)
    main = roots[int(np.argmax([np.sum(top == r) for r in roots]))]
    joined = parents.copy()
    joined[roots[roots != main]] = main
    return joined


def _chosen_skin(doc: GltfDocument, skinned: list[dict]) -> int:
    """The skin whose meshes hold the most vertices."""
    counts: dict[int, int] = {}
    for n in skinned:
        for prim in doc.items("meshes")[n["mesh"]].get("primitives", []):
            if "JOINTS_0" in prim.get("attributes", {}):
                counts[n["skin"]] = counts.get(n["skin"], 0) + doc.items("accessors")[prim["attributes"]["POSITION"]]["count"]
    if not counts:
        raise InvalidInput("skinned meshes carry no JOINTS_0", code="no_skin", field="mesh")
    return max(counts, key=counts.__getitem__)


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
        check_finite_weights(wi, s)
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
    verts: list[np.ndarray] = []
    faces: list[np.ndarray] = []
    weights: list[sp.spmatrix] = []
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
    order = skeleton.file_order  # skin slot of each of our joints
    return RiggedAsset(vertices, np.concatenate(faces), skeleton, w.astype(np.float32).tocsr()[:, order],
                       joints[order], bind[order], skin_index)


def used_joints(skeleton: Skeleton, weights: sp.csr_matrix, eps: float = 1e-6) -> np.ndarray:
    """(J,) bool: joints that influence a vertex or have a descendant that does."""
    keep = np.asarray(weights.max(axis=0).todense()).ravel() > eps
    for jnt in np.flatnonzero(keep):
        p = skeleton.parents[jnt]
        while p >= 0 and not keep[p]:
            keep[p] = True
            p = skeleton.parents[p]
    return keep
