"""Separate mesh parts with at most one joint to bend about follow one joint alone.

Characters are often built of separate pieces (armour plates, robot segments, eyes, buttons, joint covers,
wheels, shields) that artists bind rigidly to one bone: such a piece never needs to bend, and blending it
between bones stretches it wherever the bones turn apart. A part is a connected component of the welded surface.
In a mesh of several parts, a part with no joint inside its bounding box is bound to the joint it leans on most,
however its weight is spread (with no joint to bend about, a piece that blends between bones, an eye between
head and neck, can only stretch), and a part holding one joint is bound to that joint when at least RIGID_SHARE
of its weight mass lies on one joint (a wheel, a cart, a shield). A part holding two joints or more keeps the
method's blend, whatever its size: `rigforge eval parts ../shared/corpus --split train` counts how artists bind
each class (pieces: box diagonal up to MAX_PIECE of the whole mesh's), and such parts are rigid in only 30 %
(pieces) and 8 % (large parts) of the artists' rigs. A mesh of one piece is left as it is.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

RIGID_SHARE = 0.5  # a part with at least this share of its weight mass on one joint follows that joint alone
MAX_PIECE = 0.35  # only parts whose box diagonal is at most this share of the whole mesh's are pieces


@dataclass
class PartFigures:
    """Per connected part: mass (parts, J) its weight mass on each joint; size (parts,) its bounding-box diagonal over
    the whole mesh's; held (parts,) the given joints inside its box (None when no joint was given)."""

    mass: np.ndarray
    size: np.ndarray
    held: np.ndarray | None


def part_figures(vertices: np.ndarray, labels: np.ndarray, weights: sp.spmatrix, joints: np.ndarray | None = None) -> PartFigures:
    """The figures the rigid-part rule reads, for (V, 3) vertices, their (V,) part labels, (V, J) weights and
    optionally (J', 3) joint positions."""
    count = int(labels.max()) + 1 if len(labels) else 0
    members = sp.csr_matrix((np.ones(len(labels)), (labels, np.arange(len(labels)))), shape=(count, len(labels)))
    mass = np.asarray((members @ sp.csr_matrix(weights)).todense())
    lo = np.full((count, 3), np.inf)
    hi = np.full((count, 3), -np.inf)
    np.minimum.at(lo, labels, vertices)
    np.maximum.at(hi, labels, vertices)
    whole = float(np.linalg.norm(np.ptp(vertices, axis=0))) if len(vertices) else 0.0
    held = None
    if joints is not None and len(joints):
        j = np.asarray(joints, np.float64).reshape(-1, 3)
        held = np.all((j[None] >= lo[:, None]) & (j[None] <= hi[:, None]), axis=2).sum(axis=1)
    return PartFigures(mass, np.linalg.norm(hi - lo, axis=1) / (whole or 1.0), held)


def bind_rigid_parts(vertices: np.ndarray, labels: np.ndarray, weights: sp.csr_matrix, joints: np.ndarray,
                     share: float = RIGID_SHARE) -> sp.csr_matrix:
    """(V, J) CSR `weights` with every part that holds none of `joints` (J', 3) in its box, or holds one and puts
    at least `share` of its weight mass on one joint, bound to that joint alone (see the module docstring).
    vertices (V, 3): the mesh the weights are for; labels (V,) int: its `part_labels`."""
    count = int(labels.max()) + 1 if len(labels) else 0
    if count < 2:
        return weights
    w = sp.csr_matrix(weights)
    fig = part_figures(vertices, labels, w, joints)
    total = fig.mass.sum(axis=1)
    top = fig.mass.argmax(axis=1)
    held = fig.held if fig.held is not None else np.zeros(count, np.int64)  # no joint given: none is held
    leaning = fig.mass[np.arange(count), top] >= share * total
    rigid = (total > 0) & ((held == 0) | ((held == 1) & leaning))
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


def rigid_piece_vertices(labels: np.ndarray, weights: sp.csr_matrix) -> np.ndarray:
    """(V,) bool: the vertices of separate parts (labels (V,) int, `part_labels`; a mesh of several) that ride one
    joint alone, every vertex of the part on the same joint with no other influence. Such a piece is rigid by the
    rig's own account: nothing it is bound to can bend or squash it."""
    count = int(labels.max()) + 1 if len(labels) else 0
    if count < 2:
        return np.zeros(len(labels), bool)
    w = sp.csr_matrix(weights, copy=True)
    w.eliminate_zeros()  # on a copy: the caller's matrix may share its arrays
    single = np.diff(w.indptr) == 1
    joint = np.full(len(labels), -1, np.int64)
    joint[single] = w.indices[w.indptr[:-1][single]]
    lo = np.full(count, np.iinfo(np.int64).max)
    hi = np.full(count, -1, np.int64)
    np.minimum.at(lo, labels, np.where(single, joint, -1))  # a vertex with several influences puts -1 in its part
    np.maximum.at(hi, labels, joint)
    return ((lo == hi) & (lo >= 0))[labels]
