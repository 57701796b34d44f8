"""Separate mesh parts that lean mostly on one joint follow that joint alone.

Characters are often built of separate pieces (armour plates, robot segments, eyes, buttons, joint covers)
that artists bind rigidly to one bone: such a piece never needs to bend, and blending it between bones
stretches it wherever the bones turn apart. A part is a connected component of the welded surface. In a mesh
of several parts, every part whose weight mass lies at least RIGID_SHARE on one joint is bound to that joint
alone. Parts that spread their weight wider (a body surface, a sleeve over an elbow) keep a blend, and so does
a part larger than MAX_PIECE of the whole (a body, not a piece, whose blend the method chose for a reason); a mesh
of one piece is left as it is.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

RIGID_SHARE = 0.5  # a part with at least this share of its weight mass on one joint follows that joint alone
MAX_PIECE = 0.35  # only parts whose box diagonal is at most this share of the whole mesh's are pieces


def _part_sizes(vertices: np.ndarray, labels: np.ndarray, count: int) -> np.ndarray:
    """(parts,) each part's bounding-box diagonal over the whole mesh's."""
    lo = np.full((count, 3), np.inf)
    hi = np.full((count, 3), -np.inf)
    np.minimum.at(lo, labels, vertices)
    np.maximum.at(hi, labels, vertices)
    whole = float(np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0))) or 1.0
    return np.linalg.norm(hi - lo, axis=1) / whole


def bind_rigid_parts(vertices: np.ndarray, labels: np.ndarray, weights: sp.csr_matrix, share: float = RIGID_SHARE,
                     max_size: float = MAX_PIECE) -> sp.csr_matrix:
    """(V, J) CSR `weights` with every part that puts at least `share` of its weight mass on one joint bound to
    that joint alone (see the module docstring). vertices (V, 3): the mesh the weights are for; labels (V,) int:
    its `part_labels`."""
    count = int(labels.max()) + 1 if len(labels) else 0
    if count < 2:
        return weights
    w = sp.csr_matrix(weights)
    members = sp.csr_matrix((np.ones(len(labels)), (labels, np.arange(len(labels)))), shape=(count, len(labels)))
    mass = np.asarray((members @ w).todense())  # (parts, J)
    total = mass.sum(axis=1)
    top = mass.argmax(axis=1)
    rigid = (total > 0) & (mass[np.arange(count), top] >= share * total) & (_part_sizes(vertices, labels, count) <= max_size)
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
