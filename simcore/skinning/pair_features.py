"""Inputs of the learned skinning model: for every vertex, its K candidate bones and what relates them.

Candidates are the K joints nearest through the solid (geodesic voxel distance, the cue UniRig's skinning
model consumes and the strongest one we compute). Every length is in unit-cube units (the mesh's bounding
box, longest side 1), so the features do not depend on the character's size or vertex density.

Per vertex-bone pair (PAIR_FEATURES): geodesic and straight distance to the joint's bone segments, both
again relative to the vertex's nearest joint, the position along the nearest segment, the geodesic
method's log-weight, the rank, how the joint sits in the tree relative to the vertex's nearest joint
(same, parent, child, sibling, other), whether the surface normal faces away from the bone, and the same
distance seen by the vertex's whole island (connected surface part): the island's mean geodesic distance to
the joint, relative to the island's nearest joint, and whether the joint is that nearest one. Game and
low-poly characters are often built from separate parts that artists bind rigidly to one bone; the island
features let the model see a part as a whole.
Per bone (BONE_FEATURES): head, mean tail, length, depth, child count, leaf and root flags.
Per vertex (POINT_FEATURES): position, normal, nearest geodesic and straight distances, the island's share of
the vertices and its bounding-box diagonal.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp
import trimesh
from scipy.sparse.csgraph import connected_components
from scipy.spatial.transform import Rotation

from simcore.arrays import smallest_k
from simcore.geometry.laplacian import adjacency
from simcore.geometry.weld import weld_vertices
from simcore.metrics.skinning import unit_cube_frame
from simcore.skeleton.types import Skeleton, tree_depths
from simcore.skinning.bones import closest_on_segments, joint_segments
from simcore.skinning.geodesic import DISTANCE_UNIT, LEAF_EXTENSION, falloff_weights, geodesic_distances

CANDIDATES = 16  # joints per vertex: artists blend a vertex between a few nearby bones, never distant ones
PAIR_FEATURES = 18
BONE_FEATURES = 11
POINT_FEATURES = 10
VECTOR_COLUMNS = (0, 3)  # first columns of the 3-vectors of the point (position, normal) and bone (head, tail) features
FAR = 4.0  # unit-cube distance standing in for a joint the solid does not connect to the vertex
EPS = DISTANCE_UNIT  # softens ratios of distances near a bone


@dataclass
class SkinInputs:
    """candidates: (V, K) int64 joint ids; pair: (V, K, PAIR_FEATURES); bone: (J, BONE_FEATURES);
    point: (V, POINT_FEATURES), all float32; prior: (V, K) float32 geodesic log-weights (row max 0)."""

    candidates: np.ndarray
    pair: np.ndarray
    bone: np.ndarray
    point: np.ndarray
    prior: np.ndarray


def turned(inputs: SkinInputs, angle: float) -> SkinInputs:
    """`inputs` of the character turned by `angle` radians about the up axis (+Y) through its centre: only the point
    and bone vectors move; distances, relations and the prior do not depend on the turn."""
    rotation = Rotation.from_rotvec([0.0, angle, 0.0]).as_matrix().astype(np.float32)
    point, bone = inputs.point.copy(), inputs.bone.copy()
    for c in VECTOR_COLUMNS:
        point[:, c:c + 3] = point[:, c:c + 3] @ rotation.T
        bone[:, c:c + 3] = bone[:, c:c + 3] @ rotation.T
    return replace(inputs, point=point, bone=bone)


def bone_features(skeleton: Skeleton, centre: np.ndarray, side: float) -> np.ndarray:
    """(J, BONE_FEATURES) float32: head (3), mean child head or extended leaf tail (3), length, depth / max
    depth, child count / 4, leaf flag, root flag."""
    pos = (skeleton.positions - centre) / side
    kids = skeleton.children()
    parents = skeleton.parents
    tails = np.empty_like(pos)
    for j, ks in enumerate(kids):
        if ks:
            tails[j] = pos[ks].mean(axis=0)
        else:
            p = parents[j]
            tails[j] = pos[j] + LEAF_EXTENSION * (pos[j] - pos[p]) if p >= 0 else pos[j]
    depth = tree_depths(parents).astype(np.float64)
    count = np.array([len(k) for k in kids], np.float64)
    out = np.column_stack([
        pos, tails, np.linalg.norm(tails - pos, axis=1), depth / max(depth.max(), 1.0), count / 4.0,
        (count == 0).astype(np.float64), (parents < 0).astype(np.float64),
    ])
    return out.astype(np.float32)


def _relations(parents: np.ndarray, candidates: np.ndarray) -> np.ndarray:
    """(V, K, 5) one-hot: candidate is the row's first candidate, its parent, its child, its sibling, other."""
    first = candidates[:, :1]
    pc, pf = parents[candidates], parents[first]
    same = candidates == first
    parent = candidates == pf
    child = pc == first
    sibling = (pc == pf) & ~same & (pf >= 0)
    other = ~(same | parent | child | sibling)
    return np.stack([same, parent, child, sibling, other], axis=-1).astype(np.float32)


def islands(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(V,) int64 connected surface part of each vertex (coincident vertices welded first)."""
    welded = weld_vertices(vertices, faces)
    _, label = connected_components(adjacency(welded.faces, len(welded.vertices)), directed=False)
    return label[welded.index].astype(np.int64)


def island_features(vertices: np.ndarray, label: np.ndarray, geo: np.ndarray, cand: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """((V, K, 3) island-mean geodesic distance to each candidate, its log ratio to the island's nearest joint's,
    is-the-island's-nearest flag; (V, 2) island vertex share (log) and bounding-box diagonal), unit-cube units."""
    count = np.bincount(label)
    member = sp.csr_matrix((1.0 / count[label], (label, np.arange(len(label)))), shape=(len(count), len(label)))
    mean = np.asarray(member @ geo)  # (islands, J)
    best = mean.min(axis=1)
    m = mean[label[:, None], cand]  # (V, K)
    b = best[label][:, None]
    pair = np.stack([m, np.log((m + EPS) / (b + EPS)), (m <= b).astype(np.float64)], axis=-1)
    lo = np.full((len(count), 3), np.inf)
    hi = np.full((len(count), 3), -np.inf)
    np.minimum.at(lo, label, vertices)
    np.maximum.at(hi, label, vertices)
    point = np.column_stack([np.log(count[label] / len(label)), np.linalg.norm(hi - lo, axis=1)[label]])
    return pair, point


def _nearest_segment(dist: np.ndarray, t: np.ndarray, owner: np.ndarray, joints: int, cand: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """(V, K) straight distance from each vertex to its candidate joints' nearest segments, and the position along
    that segment. dist, t: (V, S) per segment; owner: (S,) joint of each segment; cand: (V, K) joint ids. A joint
    without segments reads as infinitely far (position 0); on equal distances the first segment counts."""
    counts = np.bincount(owner, minlength=joints)
    order = np.argsort(owner, kind="stable")
    slot = np.arange(len(owner)) - (np.cumsum(counts) - counts)[owner[order]]
    table = np.full((joints, max(int(counts.max()), 1)), len(owner))  # padding: the extra column below
    table[owner[order], slot] = order
    segs = table[cand]  # (V, K, M) segment ids of each candidate joint
    rows = np.arange(len(dist))[:, None, None]
    d = np.concatenate([dist, np.full((len(dist), 1), np.inf)], axis=1)[rows, segs]
    along = np.concatenate([t, np.zeros((len(t), 1))], axis=1)[rows, segs]
    best = np.argmin(d, axis=2)[..., None]
    return np.take_along_axis(d, best, axis=2)[..., 0], np.take_along_axis(along, best, axis=2)[..., 0]


def skin_inputs(
    vertices: np.ndarray, faces: np.ndarray, skeleton: Skeleton, *, candidates: int = CANDIDATES,
    progress: Callable[[float], None] = lambda fraction: None,
) -> SkinInputs:
    """The model's inputs for a mesh (V, 3) / (F, 3) and a skeleton in the same space."""
    v = np.asarray(vertices, dtype=np.float64)
    centre, side = unit_cube_frame(v)
    # The leaves continue their parent bones here, as the shipped model was trained (README, Skinning).
    geo = geodesic_distances(v, faces, skeleton, leaf_parts=False, progress=lambda f: progress(0.8 * f)) / side
    geo = np.where(np.isfinite(geo), geo, FAR)
    segments = joint_segments(skeleton, LEAF_EXTENSION)
    dist, t = closest_on_segments(v / side, segments.heads / side, segments.tails / side)  # (V, S)
    j = skeleton.num_joints
    k = min(candidates, j)
    cand = smallest_k(geo, k)
    g = np.take_along_axis(geo, cand, axis=1)
    e, a = _nearest_segment(dist, t, segments.owner, j, cand)
    e = np.where(np.isfinite(e), e, FAR)  # a helper joint owns no segment (bones.py): as far as an unreachable one
    prior = np.log(np.maximum(falloff_weights(g, DISTANCE_UNIT), 1e-12))
    prior -= prior.max(axis=1, keepdims=True)
    normals = trimesh.Trimesh(v, faces, process=False).vertex_normals
    heads = (skeleton.positions - centre) / side
    towards = (v - centre)[:, None, :] / side - heads[cand]  # joint head → vertex
    facing = np.einsum("vkc,vc->vk", towards, normals) / np.maximum(np.linalg.norm(towards, axis=2), 1e-9)
    g0, e0 = g[:, :1], e.min(axis=1, keepdims=True)
    island_pair, island_point = island_features((v - centre) / side, islands(v, faces), geo, cand)
    columns = [g, e, g - g0, np.log((g + EPS) / (g0 + EPS)), np.log((e + EPS) / (e0 + EPS)), a,
               np.maximum(prior, -30.0) / 30.0, np.broadcast_to(np.arange(k) / max(k - 1, 1), g.shape), facing, e - e0]
    pair = np.empty((len(v), k, PAIR_FEATURES), np.float32)  # filled column by column: no float64 (V, K, P) copy
    for c, column in enumerate(columns):
        pair[..., c] = column
    pair[..., len(columns):len(columns) + 5] = _relations(skeleton.parents, cand)
    pair[..., len(columns) + 5:] = island_pair
    point = np.column_stack([(v - centre) / side, normals, g0, e0, island_point])
    progress(1.0)
    return SkinInputs(cand, pair, bone_features(skeleton, centre, side), point.astype(np.float32),
                      prior.astype(np.float32))
