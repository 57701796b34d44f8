"""Rigged-asset extraction from a GltfDocument: bind-pose mesh, skin skeleton and per-vertex weights.

Conventions follow the glTF skinning model: vertices are the skinned primitives' POSITION in bind space
(meshes parented under a joint are moved there and follow that joint), joint bind positions are the
translations of inverse(inverseBindMatrix). A file may bind its meshes with several skins (one per mesh, or
one per part of the character); the rig is their union, expressed in the bind space of the skin covering the
most vertices. Joint parents are the nearest ancestor node that is also a joint of any of those skins.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from simcore.errors import InvalidInput
from simcore.geometry.similarity import point_spread, similarity_fit
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
    skeleton: the skins' joints (bind positions, parents, node names).
    weights:  (V, J) float32 CSR matrix, rows normalised to 1 where any weight exists.
    joint_nodes: (J,) glTF node index of each joint.
    bind_matrices: (J, 4, 4) float64 each joint's bind transform (inverse of its inverse bind matrix) in the
              reference skin's bind space.
    skin_index: the reference skin (the one whose meshes hold the most vertices).
    skins: every skin read, the reference first.
    Joints are in the skeleton's order (parents first, one root); skeleton.file_order maps them to the merged
    joint list (the reference skin's `joints` in its order, then each further skin's joints not already listed).
    """

    vertices: np.ndarray
    faces: np.ndarray
    skeleton: Skeleton
    weights: sp.csr_matrix
    joint_nodes: np.ndarray
    bind_matrices: np.ndarray
    skin_index: int = 0
    skins: tuple[int, ...] = ()


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


def _skin_binds(doc: GltfDocument, skin_index: int) -> tuple[np.ndarray, np.ndarray]:
    """(joint nodes (J,) in the skin's `joints` order, bind matrices (J, 4, 4) = inverse of each inverse bind
    matrix, in that skin's bind space; the joints' rest world matrices when the skin has none)."""
    skin = doc.items("skins")[skin_index]
    joints = np.asarray(skin.get("joints", []), dtype=np.int64)
    if len(joints) == 0:
        raise InvalidInput("skin has no joints", code="invalid_gltf", field="mesh")
    if "inverseBindMatrices" not in skin:
        return joints, doc.world_matrices()[joints]
    ibm = doc.accessor(skin["inverseBindMatrices"]).astype(np.float64).reshape(-1, 4, 4).transpose(0, 2, 1)
    if len(ibm) != len(joints):
        raise InvalidInput("inverseBindMatrices count differs from joints", code="invalid_gltf", field="mesh")
    if not np.all(np.isfinite(ibm)):
        raise InvalidInput("the skin's inverseBindMatrices hold NaN or infinite values", code="non_finite_bind", field="mesh")
    try:
        return joints, np.linalg.inv(ibm)
    except np.linalg.LinAlgError:
        raise InvalidInput("an inverse bind matrix is singular", code="invalid_gltf", field="mesh") from None


def _depth(node_parents: np.ndarray, node: int) -> int:
    """Number of ancestors of a node."""
    d = 0
    while node_parents[node] >= 0:
        node, d = int(node_parents[node]), d + 1
    return d


@dataclass
class _MergedSkins:
    """Every skin of the file as one joint set in the reference skin's bind space.

    joints: (J,) glTF nodes, the reference skin's joints first (its order), then each further skin's new ones.
    bind:   (J, 4, 4) bind matrices in the reference skin's bind space.
    slots:  skin index → (that skin's J_k,) int64 slot of each of its joints in `joints`.
    frames: skin index → (4, 4) matrix taking that skin's bind space into the reference's.
    """

    joints: np.ndarray
    bind: np.ndarray
    slots: dict[int, np.ndarray]
    frames: dict[int, np.ndarray]


def _merge_skins(doc: GltfDocument, skins: list[int], binds: dict[int, tuple[np.ndarray, np.ndarray]],
                 placements: dict[int, np.ndarray]) -> _MergedSkins:
    """Union of the skins' joints, skins[0] being the reference; `binds` is `_skin_binds` of each skin and
    `placements` each skin's bind space → scene (4, 4) at the nodes' rest pose.

    Each skin binds its meshes in its own bind space. A skin sharing joints with those already merged is
    brought into the reference's space through its shared joint nearest the scene root (the two bind matrices
    of one joint are the same joint at bind); a skin sharing none through the two skins' placements, so that
    the parts lie together at bind as they do in the scene. A shared joint keeps the bind matrix it was first
    merged with.
    """
    node_parents = doc.node_parents()
    joints: list[int] = []
    bind: list[np.ndarray] = []
    where: dict[int, int] = {}
    slots: dict[int, np.ndarray] = {}
    frames: dict[int, np.ndarray] = {}
    pending = list(skins)
    while pending:
        sharing = [k for k in pending if any(int(n) in where for n in binds[k][0])]
        k = sharing[0] if sharing else pending[0]
        pending.remove(k)
        nodes, own = binds[k]
        if not joints:
            frame = np.eye(4)
        elif sharing:
            shared = [i for i, n in enumerate(nodes) if int(n) in where]
            i = min(shared, key=lambda i: _depth(node_parents, int(nodes[i])))
            frame = bind[where[int(nodes[i])]] @ np.linalg.inv(own[i])
        else:
            frame = np.linalg.inv(placements[skins[0]]) @ placements[k]
        frames[k] = frame
        slot = np.empty(len(nodes), np.int64)
        for i, n in enumerate(nodes):
            if int(n) not in where:
                where[int(n)] = len(joints)
                joints.append(int(n))
                bind.append(frame @ own[i])
            slot[i] = where[int(n)]
        slots[k] = slot
    return _MergedSkins(np.asarray(joints, np.int64), np.stack(bind), slots, frames)


def _similarity(source: np.ndarray, target: np.ndarray) -> np.ndarray | None:
    """(4, 4) rotation, uniform scale and translation that best maps points `source` onto `target` (least
    squares, `similarity_fit`); None for fewer than 4 points or a degenerate spread."""
    if len(source) < 4:
        return None
    var = point_spread(source)
    if not np.isfinite(var) or var <= 1e-18:  # checked before the fit: its SVD fails on NaN
        return None
    scale, rot, shift = similarity_fit(source, target)
    if not np.isfinite(scale) or scale <= 0:
        return None
    out = np.eye(4)
    out[:3, :3] = scale * rot
    out[:3, 3] = shift
    return out


def _skin_placement(doc: GltfDocument, nodes: np.ndarray, bind: np.ndarray,
                    parts: list[tuple[np.ndarray, sp.coo_matrix]]) -> np.ndarray:
    """(4, 4) where a skin's bind space lies in the scene at the nodes' rest pose: the similarity that best
    maps its meshes' bind-space vertices onto where the rest pose skins them (robust to a posed root); the
    root-most joint's rest world · inverse bind when the meshes are too few or flat to fit."""
    rest = doc.world_matrices()[nodes] @ np.linalg.inv(bind)  # (J, 4, 4) joint matrices at rest
    if parts:
        v = np.concatenate([p[0] for p in parts])
        w = sp.vstack([p[1] for p in parts]).tocsr()
        sums = np.asarray(w.sum(axis=1)).ravel()
        ok = sums > 0
        blended = np.asarray((sp.diags(1.0 / np.where(ok, sums, 1.0)) @ w) @ rest[:, :3].reshape(len(rest), 12))
        blended = blended.reshape(-1, 3, 4)
        skinned = np.einsum("vab,vb->va", blended[:, :, :3], v) + blended[:, :, 3]
        fit = _similarity(v[ok], skinned[ok])
        if fit is not None:
            return fit
    node_parents = doc.node_parents()
    root_most = min(range(len(nodes)), key=lambda i: _depth(node_parents, int(nodes[i])))
    return rest[root_most]


def _merged_skeleton(doc: GltfDocument, joints: np.ndarray, bind: np.ndarray) -> Skeleton:
    """(skeleton in our layout) of the joint nodes `joints` with their bind matrices.

    A joint's parent is its nearest ancestor node that is also a joint. glTF lets skins list joints in any
    order and have several roots; the skeleton is one tree with parents first: extra roots hang from the root
    with the most joints under it, and `file_order` / `file_parents` keep the layout of `joints` for export.
    skeleton.file_order[i] is joint i's position in `joints`.
    """
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
    return slot_skeleton.reordered(order)


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


def _skinned_vertex_counts(doc: GltfDocument, skinned: list[dict]) -> dict[int, int]:
    """Skin index → vertices of the primitives with JOINTS_0 that it binds (skins no such mesh uses are absent)."""
    counts: dict[int, int] = {}
    for n in skinned:
        for prim in doc.items("meshes")[n["mesh"]].get("primitives", []):
            attrs = prim.get("attributes", {})
            if "JOINTS_0" in attrs and "POSITION" in attrs:
                counts[n["skin"]] = counts.get(n["skin"], 0) + doc.items("accessors")[attrs["POSITION"]]["count"]
    if not counts:
        raise InvalidInput("skinned meshes carry no JOINTS_0", code="no_skin", field="mesh")
    return counts


def _skinned_part(doc: GltfDocument, prim: dict, j: int) -> tuple[np.ndarray, sp.coo_matrix] | None:
    """(vertices in its skin's bind space, (V, j) weights over that skin's j joints) of one skinned primitive;
    None when it has no skin attributes."""
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
    if not vals:
        raise InvalidInput("JOINTS_0 comes without WEIGHTS_0", code="invalid_gltf", field="mesh")
    return v, sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(len(v), j))


def carrying_joint(parents: np.ndarray, slot: dict[int, int], node: int) -> int | None:
    """The joint that carries node `node` (itself or its nearest joint ancestor), as its value in `slot` (joint
    node → slot), or None under no joint. parents: (N,) every node's parent node (`GltfDocument.node_parents`)."""
    while node >= 0 and node not in slot:
        node = int(parents[node])
    return slot.get(node)


def read_rigged_asset(doc: GltfDocument) -> RiggedAsset:
    """Extract the file's rig: the union of every skin a skinned mesh uses; raise InvalidInput when the file
    has no skinned mesh.

    The skin covering most vertices is the reference: its bind space is the asset's, and the other skins'
    meshes and joints are brought into it (`_merge_skins`); joints shared by several skins are one joint, and
    each vertex's weights go to the merged joints. Unskinned meshes parented under a joint (a robot's rigid
    parts) follow that joint with weight 1 and are moved into bind space (bind @ inverse(joint's rest world) @
    node world).
    """
    nodes = doc.items("nodes")
    meshes = doc.items("meshes")
    skinned = [n for n in nodes if "skin" in n and "mesh" in n]
    if not skinned:
        raise InvalidInput("the file has no skinned mesh", code="no_skin", field="mesh")
    counts = _skinned_vertex_counts(doc, skinned)
    if any(not 0 <= k < len(doc.items("skins")) for k in counts):
        raise InvalidInput("a mesh node refers to a skin that does not exist", code="invalid_gltf", field="mesh")
    skin_order = sorted(counts, key=lambda k: (-counts[k], k))
    binds = {k: _skin_binds(doc, k) for k in skin_order}
    skin_parts: dict[int, list[tuple[dict, tuple[np.ndarray, sp.coo_matrix] | None]]] = {}  # by mesh node
    for index, node in enumerate(nodes):
        if "mesh" in node and int(node.get("skin", -1)) in binds:
            j_k = len(binds[int(node["skin"])][0])
            skin_parts[index] = [(prim, _skinned_part(doc, prim, j_k)) for prim in meshes[node["mesh"]].get("primitives", [])]
    placements = {}
    if len(skin_order) > 1:
        for k in skin_order:
            own = [part for i, ps in skin_parts.items() if int(nodes[i]["skin"]) == k for _, part in ps if part is not None]
            placements[k] = _skin_placement(doc, *binds[k], own)
    merged = _merge_skins(doc, skin_order, binds, placements)
    joints, bind = merged.joints, merged.bind
    skeleton = _merged_skeleton(doc, joints, bind)
    j = skeleton.num_joints
    world, node_parents = doc.world_matrices(), doc.node_parents()
    joint_slots = {int(n): k for k, n in enumerate(joints)}
    verts: list[np.ndarray] = []
    faces: list[np.ndarray] = []
    weights: list[sp.spmatrix] = []
    for index, node in enumerate(nodes):
        if "mesh" not in node:
            continue
        parts: list[tuple[dict, tuple[np.ndarray, sp.spmatrix] | None]] = []
        if index in skin_parts:
            k = int(node["skin"])
            frame, slots = merged.frames[k], merged.slots[k]
            for prim, part in skin_parts[index]:
                if part is not None:
                    w = part[1]
                    part = (part[0] @ frame[:3, :3].T + frame[:3, 3], sp.coo_matrix((w.data, (w.row, slots[w.col])), shape=(len(part[0]), j)))
                parts.append((prim, part))
        elif "skin" not in node:
            slot = carrying_joint(node_parents, joint_slots, index)
            if slot is None:
                continue
            to_bind = bind[slot] @ np.linalg.inv(world[joints[slot]]) @ world[index]
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
    order = skeleton.file_order  # position in `joints` of each of our joints
    return RiggedAsset(vertices, np.concatenate(faces), skeleton, w.astype(np.float32).tocsr()[:, order],
                       joints[order], bind[order], skin_order[0], tuple(skin_order))


def rig_rest_matrices(doc: GltfDocument, asset: RiggedAsset, world: np.ndarray | None = None) -> np.ndarray:
    """(J, 4, 4) joint world @ inverse bind, in the asset's joint order: the glTF joint matrices that place the
    asset's bind-space vertices where the file shows them (world None: the nodes' rest pose), or where the
    node world transforms `world` (N, 4, 4) put them."""
    world = doc.world_matrices() if world is None else world
    return world[asset.joint_nodes] @ np.linalg.inv(asset.bind_matrices)


def _weighted(weights: sp.spmatrix, eps: float) -> np.ndarray:
    """(J,) bool: joints some vertex of the (V, J) weights follows by more than `eps`."""
    return np.asarray(sp.csr_matrix(weights).max(axis=0).todense()).ravel() > eps


ARMATURE_SHARE = 0.01  # a root holding at most this share of the weight is an armature root, not a body joint


def root_holds_weight(weights: sp.spmatrix) -> bool:
    """Whether a rig's root (joint 0) is a body joint that bends the mesh: more than ARMATURE_SHARE of its (V, J)
    weights' mass is on it. Most artist rigs hang the body from an armature root that holds none."""
    column = np.asarray(sp.csr_matrix(weights).sum(axis=0)).ravel()
    return bool(column.sum() > 0 and column[0] > ARMATURE_SHARE * column.sum())


def weightless_joints(weights: sp.spmatrix, eps: float = 1e-6) -> np.ndarray:
    """(J,) bool: joints of a rig (parents first) that no vertex of its (V, J) weights follows (pole targets,
    bone-end markers, sockets), the root (index 0) aside, which every tree keeps; all False when no joint holds
    weight (an unweighted skin tells nothing)."""
    held = _weighted(weights, eps)
    out = ~held if held.any() else np.zeros(len(held), bool)
    out[:1] = False
    return out


def used_joints(skeleton: Skeleton, weights: sp.csr_matrix, eps: float = 1e-6) -> np.ndarray:
    """(J,) bool: joints that influence a vertex or have a descendant that does."""
    keep = _weighted(weights, eps)
    for jnt in np.flatnonzero(keep):
        p = skeleton.parents[jnt]
        while p >= 0 and not keep[p]:
            keep[p] = True
            p = skeleton.parents[p]
    return keep
