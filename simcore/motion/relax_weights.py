"""Skin weights relaxed under the clip a job plays: where a frame crushes or stretches an edge past TOLERANCE, the
weights around it move, as little as the clip needs.

The skin stage predicts weights without the motion; the motion stage knows every frame the character will play.
The weights of the vertices within RINGS edges of an edge whose length leaves (1 ± TOLERANCE) × its bind length in
some frame are moved by projected gradient descent (Adam steps, each row projected back onto the simplex) on

    Σ_edges mean_frames max(0, |length / bind length − 1| − TOLERANCE)²  +  CLOSENESS · Σ_vertices |w − w₀|²

over the joints the vertex or its neighbours already use (no joint enters a region it had no weight in). On a mesh
that encloses a volume, each frame's volume change past VOLUME_TOLERANCE adds its square, as if every edge the loss
reads had that excess (the volume is the quality gate's). Every other vertex keeps its weights bit for bit, and so
does any part no frame deforms. The work is on the welded surface (seam copies of a vertex keep one row, as the skin
stage leaves them). Frames: the FRAMES / 2 with the worst edge tails and FRAMES / 2 evenly spaced over the clip; the
loss looks at those, the edges past the tolerance are counted at every frame. The constants' sweep is in the README (Motion section).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import torch

from simcore.arrays import smallest_k
from simcore.gate.measures import MIN_ENCLOSED, edge_ratios, lbs_blocks, measured_edges
from simcore.geometry.laplacian import adjacency
from simcore.geometry.weld import weld_vertices
from simcore.mpm.measures import part_centres, part_volumes, volume_parts
from simcore.skinning.lbs import linear_blend
from simcore.skinning.postprocess import top_k

TOLERANCE = 0.02  # |stretch − 1| an edge may reach at no cost (chosen with CLOSENESS: README, Motion section)
VOLUME_TOLERANCE = 0.02  # |volume / bind volume − 1| a frame may reach at no cost
CLOSENESS = 0.003  # cost of a squared weight change against a squared excess stretch of one edge in every frame
RINGS = 2  # vertices this many edges from an offending edge may move, so a blend can widen
CANDIDATES = 8  # joints a moving vertex may share weight between: its own first, then its neighbours' by mass
FRAMES = 32
STEPS = 80
STEP_SIZE = 0.02
MAX_TERMS = 2_000_000  # frames × moving vertices × candidates per step: bounds the time (≈ 0.2 s a step here) and memory
CHUNK_ROWS = 4096  # moving vertices whose candidate positions are computed at once
DENSE_ROWS = 32_768  # moving vertices whose rows are made dense over the joints at once


@dataclass
class Relaxation:
    """weights: (V, J) float32 CSR, rows summing to 1; the figures are for report["motion"]["relaxation"]."""

    weights: sp.csr_matrix
    vertices_moved: int
    edges_over: int  # edges past the tolerance in some frame of the clip, before (the gate measures the result)
    mean_row_change: float  # mean L1 change of a moved vertex's row

    def figures(self) -> dict[str, float | int]:
        return {"vertices_moved": self.vertices_moved, "edges_over": self.edges_over,
                "mean_row_change": round(self.mean_row_change, 5),
                "tolerance": TOLERANCE}


def _stretch(vertices: np.ndarray, weights: sp.csr_matrix, mats: np.ndarray, e: np.ndarray,
             rest: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """((E,) worst |length / bind length − 1| of each edge over the frames, (T,) each frame's 99th percentile of it),
    posed as the quality gate poses a clip."""
    worst = np.zeros(len(e))
    tails = []
    for posed in lbs_blocks(vertices, weights, mats):
        deviation = np.abs(edge_ratios(posed, e, rest) - 1.0)
        worst = np.maximum(worst, deviation.max(axis=0))
        tails.append(np.percentile(deviation, 99.0, axis=1))
    return worst, np.concatenate(tails)


def _frames(tails: np.ndarray, count: int) -> np.ndarray:
    """Sorted frame ids: the count / 2 with the largest tails and count / 2 evenly spaced."""
    if len(tails) <= count:
        return np.arange(len(tails))
    worst = np.argsort(-tails, kind="stable")[:count // 2]
    even = np.linspace(0, len(tails) - 1, count - count // 2).round().astype(np.int64)
    return np.unique(np.r_[worst, even])


def _candidates(w0: sp.csr_matrix, near: sp.csr_matrix, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """((N, K) joint ids, (N, K) bool real, (N, K) their weights) for `rows`: the joints the row uses, then its
    neighbours' by mass (dense over the joints one block of rows at a time)."""
    k = min(CANDIDATES, w0.shape[1])
    ids, real, start = (np.empty((len(rows), k), t) for t in (np.int64, bool, np.float64))
    for c in range(0, len(rows), DENSE_ROWS):
        part = slice(c, c + DENSE_ROWS)
        own = w0[rows[part]].toarray()
        score = (near[rows[part]] @ w0).toarray() + 2.0 * (own > 0)  # a row's own joints first: its weights stay representable
        ids[part] = smallest_k(-score, k)
        real[part] = np.take_along_axis(score, ids[part], axis=1) > 0
        start[part] = np.take_along_axis(own, ids[part], axis=1)
    return ids, real, start


def _placed(ids: np.ndarray, values: np.ndarray, joints: int, max_influences: int) -> sp.csr_matrix:
    """(N, joints) CSR of each row's `values` (N, K) at its joints `ids`, top `max_influences` kept."""
    blocks = []
    for c in range(0, len(ids), DENSE_ROWS):
        dense = np.zeros((len(ids[c:c + DENSE_ROWS]), joints))
        np.put_along_axis(dense, ids[c:c + DENSE_ROWS], values[c:c + DENSE_ROWS], axis=1)
        blocks.append(top_k(dense, max_influences))
    return sp.csr_matrix(sp.vstack(blocks))


def _project(w: torch.Tensor, real: torch.Tensor) -> torch.Tensor:
    """Rows of `w` (N, K) projected onto the probability simplex over their `real` entries (Duchi et al. 2008)."""
    v = w.masked_fill(~real, -1e9)
    u, _ = torch.sort(v, dim=1, descending=True)
    cum = torch.cumsum(u, dim=1) - 1.0
    ks = torch.arange(1, w.shape[1] + 1, dtype=w.dtype)
    rho = ((u - cum / ks) > 0).sum(dim=1, keepdim=True).clamp(min=1)
    theta = torch.gather(cum, 1, rho - 1) / rho
    return torch.clamp(v - theta, min=0.0) * real


def relax_weights(vertices: np.ndarray, faces: np.ndarray, weights: sp.csr_matrix, mats: np.ndarray,
                  max_influences: int = 4) -> Relaxation:
    """`weights` (V, J) of the bind mesh vertices (V, 3) / faces (F, 3) relaxed under the clip's skinning
    matrices mats (T, J, 4, 4); see the module docstring."""
    welded = weld_vertices(vertices, faces)
    v, f = welded.vertices, welded.faces
    first = np.unique(welded.index, return_index=True)[1]
    w0 = sp.csr_matrix(weights, dtype=np.float64)[first]
    e, rest = measured_edges(v, f)
    unchanged = sp.csr_matrix(weights, dtype=np.float32)
    if not len(e) or not len(mats):
        return Relaxation(unchanged, 0, 0, 0.0)
    worst, tails = _stretch(v, w0, mats, e, rest)
    over = worst > TOLERANCE
    if not over.any():
        return Relaxation(unchanged, 0, 0, 0.0)
    adj = adjacency(f, len(v))
    near = (adj + sp.identity(len(v), format="csr")).tocsr()
    moving = np.zeros(len(v), bool)
    moving[e[over].ravel()] = True
    for _ in range(RINGS):
        moving |= np.asarray(near @ moving.astype(np.float64)).ravel() > 0
    rows = np.flatnonzero(moving)
    ids, real, start = _candidates(w0, near, rows)
    frames = _frames(tails, max(2, min(FRAMES, MAX_TERMS // max(len(rows) * ids.shape[1], 1))))
    region = _Region.around(moving, rows, e, rest, f)
    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # its tensors are small: more threads only wait on each other, the more on a busy machine
    try:
        new = _descend(v, w0, mats[frames], region, ids, real, start, _volume_loss(v, f, w0, mats[frames], region))
    finally:
        torch.set_num_threads(threads)
    place = sp.csr_matrix((np.ones(len(rows)), (rows, np.arange(len(rows)))), shape=(len(v), len(rows)))
    relaxed = sp.csr_matrix(sp.diags((~moving).astype(np.float64)) @ w0
                            + place @ _placed(ids, new, w0.shape[1], max_influences))
    change = float(np.abs((relaxed - w0)[rows]).sum(axis=1).mean())
    out = sp.csr_matrix(relaxed[welded.index], dtype=np.float32)
    out.eliminate_zeros()
    return Relaxation(out, len(rows), int(over.sum()), change)


@dataclass
class _Region:
    """What the descent reads: the moving rows, then the other ends of every edge with a moving vertex (`ends`, the
    moving rows first), those edges and the faces touching a moving vertex (both as ids into `ends`)."""

    ends: np.ndarray
    moving: int  # ends[:moving] are the moving rows, in order
    edges: np.ndarray
    rest: np.ndarray
    faces: np.ndarray
    touching: np.ndarray  # (F,) bool: the mesh's faces with a moving corner

    @classmethod
    def around(cls, moving: np.ndarray, rows: np.ndarray, e: np.ndarray, rest: np.ndarray, f: np.ndarray) -> _Region:
        read = moving[e[:, 0]] | moving[e[:, 1]]
        others = np.unique(e[read].ravel())  # every corner of a touching face is here: an edge joins it to a mover
        ends = np.r_[rows, others[~moving[others]]]
        local = np.full(len(moving), -1)
        local[ends] = np.arange(len(ends))
        touching = moving[f].any(axis=1)
        return cls(ends, len(rows), local[e[read]], rest[read], local[f[touching]], touching)


def _triple(a: torch.Tensor, b: torch.Tensor, c: torch.Tensor) -> torch.Tensor:
    """a · (b × c) over the last axis (written out: torch.linalg.cross is several times slower on CPU)."""
    return (a[..., 0] * (b[..., 1] * c[..., 2] - b[..., 2] * c[..., 1])
            + a[..., 1] * (b[..., 2] * c[..., 0] - b[..., 0] * c[..., 2])
            + a[..., 2] * (b[..., 0] * c[..., 1] - b[..., 1] * c[..., 0]))


def _volume_loss(v: np.ndarray, f: np.ndarray, w0: sp.csr_matrix, mats: np.ndarray, region: _Region
                 ) -> Callable[[torch.Tensor], torch.Tensor] | None:
    """Squared excess of each frame's volume change over VOLUME_TOLERANCE (mean over frames) as a function of the
    region's positions (M, T, 3); None when the mesh encloses no volume. The volume is the quality gate's (parts'
    cones from their own centres); the centres stay where the skin stage's weights put them, and the faces away
    from the moving vertices are a constant per frame."""
    parts = volume_parts(v, f)
    bind = float(part_volumes(v, f, parts).sum())
    if abs(bind) <= MIN_ENCLOSED * float(np.prod(np.ptp(v, axis=0))):
        return None
    apex = np.empty((len(region.faces), len(mats), 3))
    constant = np.empty(len(mats))
    for t, frame in enumerate(mats):
        posed = linear_blend(v, w0, frame)
        apex[:, t] = part_centres(posed, f, parts)[parts[region.touching]]
        a, b, c = (posed[f[region.touching][:, k]] - apex[:, t] for k in range(3))
        constant[t] = part_volumes(posed, f, parts).sum() - np.einsum("fi,fi->", a, np.cross(b, c)) / 6.0
    apex_t, constant_t = torch.from_numpy(apex.astype(np.float32)), torch.from_numpy(constant.astype(np.float32))
    corners = [torch.from_numpy(region.faces[:, k]) for k in range(3)]

    def loss(pos: torch.Tensor) -> torch.Tensor:
        a, b, c = (torch.index_select(pos, 0, k) - apex_t for k in corners)  # (F', T, 3)
        volume = constant_t + _triple(a, b, c).sum(dim=0) / 6.0
        return (torch.relu((volume / bind - 1.0).abs() - VOLUME_TOLERANCE) ** 2).mean()

    return loss


def _descend(v: np.ndarray, w0: sp.csr_matrix, mats: np.ndarray, region: _Region, ids: np.ndarray, real: np.ndarray,
             weights: np.ndarray, volume: Callable[[torch.Tensor], torch.Tensor] | None) -> np.ndarray:
    """(N, K) weights of the region's moving rows over their candidate joints `ids` (starting from `weights`) after
    the descent. Positions are vertex-major (M, T, 3): the moving rows' are blended, the other ends' fixed."""
    rows, fixed = region.ends[:region.moving], region.ends[region.moving:]
    fixed_t = torch.from_numpy(linear_blend(v[fixed], w0[fixed], mats).transpose(1, 0, 2).astype(np.float32))
    under = np.empty((len(rows), ids.shape[1], len(mats), 3), np.float32)  # each row's place under each candidate
    for c in range(0, len(rows), CHUNK_ROWS):
        part = slice(c, c + CHUNK_ROWS)
        m = mats[:, ids[part], :3, :]  # (T, c, K, 3, 4)
        under[part] = (np.einsum("tnkab,nb->nkta", m[..., :3], v[rows[part]]) + m[..., 3].transpose(1, 2, 0, 3))
    under_t = torch.from_numpy(under)
    start = torch.from_numpy(weights.astype(np.float32))
    mask = torch.from_numpy(real)
    a, b = torch.from_numpy(region.edges[:, 0]), torch.from_numpy(region.edges[:, 1])
    rest_t = torch.from_numpy(region.rest.astype(np.float32))[:, None]
    w = start.clone().requires_grad_(True)
    optimiser = torch.optim.Adam([w], lr=STEP_SIZE)
    for _ in range(STEPS):
        optimiser.zero_grad()
        pos = torch.cat([torch.einsum("nktc,nk->ntc", under_t, w), fixed_t])
        length = torch.linalg.norm(torch.index_select(pos, 0, a) - torch.index_select(pos, 0, b), dim=2).clamp(min=1e-12)
        excess = torch.relu((length / rest_t - 1.0).abs() - TOLERANCE)  # (E', T)
        loss = (excess**2).mean(dim=1).sum() + CLOSENESS * ((w - start) ** 2).sum()
        if volume is not None:  # the volume counts as the same excess on every edge the loss reads would
            loss = loss + len(region.edges) * volume(pos)
        loss.backward()
        with torch.no_grad():  # only moves along the simplex: a shift of every weight alike is no move at all
            assert w.grad is not None
            g = w.grad * mask
            g -= mask * (g.sum(dim=1, keepdim=True) / mask.sum(dim=1, keepdim=True).clamp(min=1))
            w.grad.copy_(g)
        optimiser.step()
        with torch.no_grad():
            w.copy_(_project(w, mask))
    return w.detach().double().numpy()
