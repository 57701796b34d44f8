"""Separate mesh parts follow the bones that run through them, and one joint alone when one dominates.

Characters are often built of separate pieces (armour plates, robot segments, eyes, buttons, joint covers)
that artists bind rigidly to one bone: such a piece never needs to bend, and blending it between bones
stretches it wherever the bones turn apart. A part is a connected component of the welded surface. In a mesh
of several parts, each part first keeps only the joints whose bones run through it (its own stretch of the
bone chain, `restrict_to_covering_joints`): a joint whose bone merely starts at the part's edge (a hip joint
at the bottom of a torso piece) does not move it. Then every part whose weight mass lies at least
RIGID_SHARE on one joint is bound to that joint alone (`bind_rigid_parts`). Parts that spread their weight
wider (a body surface, a sleeve over an elbow) keep a blend, and a mesh of one piece is left as it is.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from simcore.geometry.laplacian import adjacency
from simcore.geometry.weld import weld_vertices
from simcore.skeleton.types import Skeleton
from simcore.skinning.bones import joint_segments

RIGID_SHARE = 0.5  # a part with at least this share of its weight mass on one joint follows that joint alone


def part_labels(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(V,) int64 connected-component label of each vertex of the welded surface (seam duplicates share one)."""
    welded = weld_vertices(vertices, faces)
    _, label = connected_components(adjacency(welded.faces, len(welded.vertices)), directed=False)
    return np.asarray(label, np.int64)[welded.index]


def respect_parts(vertices: np.ndarray, faces: np.ndarray, skeleton: Skeleton, weights: sp.csr_matrix) -> sp.csr_matrix:
    """(V, J) CSR `weights` after both rules of the module docstring; vertices (V, 3), faces (F, 3) int."""
    return bind_rigid_parts(vertices, faces, restrict_to_covering_joints(vertices, faces, skeleton, weights))


def bind_rigid_parts(vertices: np.ndarray, faces: np.ndarray, weights: sp.csr_matrix, share: float = RIGID_SHARE) -> sp.csr_matrix:
    """(V, J) CSR `weights` with every part that puts at least `share` of its weight mass on one joint bound to
    that joint alone (see the module docstring). vertices (V, 3), faces (F, 3) int: the mesh the weights are for."""
    labels = part_labels(vertices, faces)
    count = int(labels.max()) + 1 if len(labels) else 0
    if count < 2:
        return weights
    w = sp.csr_matrix(weights)
    members = sp.csr_matrix((np.ones(len(labels)), (labels, np.arange(len(labels)))), shape=(count, len(labels)))
    mass = np.asarray((members @ w).todense())  # (parts, J)
    total = mass.sum(axis=1)
    top = mass.argmax(axis=1)
    rigid = (total > 0) & (mass[np.arange(count), top] >= share * total)
    rows = np.flatnonzero(rigid[labels])
    if not len(rows):
        return w
    keep = np.ones(w.shape[0], bool)
    keep[rows] = False
    bound = sp.csr_matrix((np.ones(len(rows), dtype=w.dtype), (rows, top[labels[rows]])), shape=w.shape)
    out = (sp.diags(keep.astype(w.dtype)) @ w + bound).tocsr()
    out.eliminate_zeros()
    out.sort_indices()
    return out


BONE_SAMPLES = 16  # points along each bone, each credited to the parts whose surface lies about as near as the nearest
NEAREST = 32  # vertices looked at around each bone point
LAYER_SLACK = 1.5  # a part within this × the nearest surface's distance of a bone point claims it too (layered clothing)
MIN_COVERAGE = 0.25  # a joint moves a part only if at least this share of its bones' points lie nearest that part


def restrict_to_covering_joints(vertices: np.ndarray, faces: np.ndarray, skeleton: Skeleton, weights: sp.csr_matrix,
                                min_coverage: float = MIN_COVERAGE) -> sp.csr_matrix:
    """(V, J) CSR `weights` in which each part of a several-part mesh keeps only the joints whose bones run
    through it: at least `min_coverage` of the points along a joint's bones lie nearest that part's vertices
    (the part's own stretch of the bone chain); a point is credited to every part whose surface lies within
    LAYER_SLACK × the nearest surface's distance of it, so layers over one limb share it. A part no bone runs
    through keeps its weights, and so does a vertex left with none. Rows are renormalised."""
    labels = part_labels(vertices, faces)
    count = int(labels.max()) + 1 if len(labels) else 0
    if count < 2:
        return weights
    seg = joint_segments(skeleton)
    t = (np.arange(BONE_SAMPLES) + 0.5) / BONE_SAMPLES
    points = (seg.heads[:, None] + t[None, :, None] * (seg.tails - seg.heads)[:, None]).reshape(-1, 3)
    owner = np.repeat(seg.owner, BONE_SAMPLES)
    k = min(NEAREST, len(vertices))
    dist, index = cKDTree(vertices).query(points, k=k)
    dist, index = dist.reshape(len(points), k), index.reshape(len(points), k)
    near = dist <= LAYER_SLACK * dist[:, :1] + 1e-12  # every layer about as near as the nearest surface claims the point
    claims = np.zeros((len(points), count), bool)
    claims[np.repeat(np.arange(len(points)), k)[near.ravel()], labels[index.ravel()][near.ravel()]] = True
    hits = np.zeros((count, skeleton.num_joints))
    np.add.at(hits.T, owner, claims.astype(np.float64))
    coverage = hits / np.maximum(np.bincount(owner, minlength=skeleton.num_joints), 1)[None, :]
    allowed = coverage >= min_coverage
    allowed[~allowed.any(axis=1)] = True  # no bone runs through the part (a plate over a limb's skin): it keeps its weights
    w = sp.csr_matrix(weights, copy=True)
    rows = np.repeat(np.arange(w.shape[0]), np.diff(w.indptr))
    data = np.where(allowed[labels[rows], w.indices], w.data, 0.0)
    total = np.zeros(w.shape[0])
    np.add.at(total, rows, data)
    data = np.where(total[rows] > 0, data / np.where(total > 0, total, 1.0)[rows], w.data)
    out = sp.csr_matrix((data.astype(w.dtype), w.indices, w.indptr), shape=w.shape)
    out.eliminate_zeros()
    return out
