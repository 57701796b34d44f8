"""Compact refinement offsets: a low-rank basis plus sparse per-key residuals, within a tolerance.

Bind-space offsets D (K keys, V vertices, 3) are written as D_k ≈ Σ_j c_kj B_j + R_k: R shared basis shapes
B (the leading right singular vectors of D, times their singular values' share) weighted per key by c, and per
key a residual R_k that keeps only the vertices the basis misses by more than `tolerance`. A residual of norm r
is kept as r·min(1, (r − tol) / tol) (0 at tol, exact from 2·tol on), so every vertex ends within `tolerance`
of its offset and the kept field stays continuous (no step where vertices drop out). The rank is the one that
makes the file smallest under the writer's byte costs (a basis vertex, a residual vertex), among RANKS.
With `basis_levels` the basis is stored quantized (glTF: normalized integers, one scale per shape) and the
residual is taken after that quantization, so it also absorbs the basis' rounding.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

RANKS = (0, 4, 8, 16, 24, 32, 48, 64)  # basis sizes tried
TOLERANCE = 1e-3  # default vertex error the compact form may add, as a fraction of the character's size


@dataclass
class CompactMorphs:
    """basis: (R, V, 3) float32 shapes; coefficients: (K, R) float64 weight of each shape per key;
    residual_rows / residual_values: per key, ascending vertex indices (n_k,) and their offsets (n_k, 3) float32;
    max_error: largest vertex distance between `reconstruct` and the input offsets (before a writer's residual
    quantization); tolerance: the bound it was built for (same units)."""

    basis: np.ndarray
    coefficients: np.ndarray
    residual_rows: list[np.ndarray]
    residual_values: list[np.ndarray]
    max_error: float
    tolerance: float

    @property
    def rank(self) -> int:
        return int(len(self.basis))

    def reconstruct(self, k: int) -> np.ndarray:
        """(V, 3) float64 offsets of key k."""
        out = np.einsum("r,rva->va", self.coefficients[k], self.basis.astype(np.float64))
        out[self.residual_rows[k]] += self.residual_values[k]
        return out

    def residual_count(self) -> int:
        return int(sum(len(r) for r in self.residual_rows))


def quantize(values: np.ndarray, levels: int) -> tuple[np.ndarray, float]:
    """Signed normalized integers (int8 for levels ≤ 127, else int16) and the scale: values ≈ q / levels · scale."""
    scale = float(np.abs(values).max(initial=0.0))
    dtype = np.int8 if levels <= 127 else np.int16
    if scale == 0.0:
        return np.zeros(values.shape, dtype), 0.0
    q = np.clip(np.round(np.asarray(values, np.float64) / scale * levels), -levels, levels)
    return q.astype(dtype), scale


def _residuals(residual: np.ndarray, tolerance: float) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Per key (rows, values) of the residual (K, V, 3) kept past `tolerance`, continuously ramped in."""
    rows, values = [], []
    norm = np.linalg.norm(residual, axis=2)
    for k in range(len(residual)):
        keep = np.flatnonzero(norm[k] > tolerance)
        r = norm[k, keep]
        ramp = np.minimum(1.0, (r - tolerance) / tolerance) if tolerance > 0 else np.ones_like(r)
        rows.append(keep.astype(np.int64))
        values.append((residual[k, keep] * ramp[:, None]).astype(np.float32))
    return rows, values


def _with_rank(offsets: np.ndarray, u: np.ndarray, s: np.ndarray, vt: np.ndarray, rank: int, tolerance: float,
               basis_levels: int | None) -> CompactMorphs:
    k_count, v_count = offsets.shape[:2]
    basis = (vt[:rank] * s[:rank, None]).reshape(rank, v_count, 3)  # shapes carry the singular values
    coefficients = u[:, :rank].copy()
    if basis_levels is not None:
        for j in range(rank):
            q, scale = quantize(basis[j], basis_levels)
            basis[j] = q.astype(np.float64) / basis_levels * scale
    basis = basis.astype(np.float32)
    approx = np.einsum("kr,rva->kva", coefficients, basis.astype(np.float64)) if rank else np.zeros_like(offsets)
    residual = offsets - approx
    rows, values = _residuals(residual, tolerance)
    for k in range(k_count):  # what is left after the kept residual
        residual[k, rows[k]] -= values[k]
    error = float(np.linalg.norm(residual, axis=2).max(initial=0.0)) if v_count else 0.0
    return CompactMorphs(basis, coefficients, rows, values, error, tolerance)


def compact_offsets(offsets: np.ndarray, tolerance: float, basis_vertex_bytes: float, residual_vertex_bytes: float,
                    *, basis_levels: int | None = None, max_shapes: int | None = None) -> CompactMorphs:
    """The smallest basis + residual form of offsets (K, V, 3) within `tolerance` (offset units).

    basis_vertex_bytes / residual_vertex_bytes: what the writer spends per vertex of a basis shape / of a kept
    residual; max_shapes: cap on basis shapes + keys with a residual (e.g. a viewer's morph-target limit).
    Zero keys give the empty form: no basis shape, no residual, no error.
    """
    offsets = np.asarray(offsets, np.float64)
    k_count, v_count = offsets.shape[:2]
    flat = offsets.reshape(k_count, v_count * 3)  # not -1: zero keys leave that width undetermined
    u, s, vt = np.linalg.svd(flat, full_matrices=False)
    best: tuple[float, CompactMorphs] | None = None
    for rank in RANKS:
        if rank > 0 and (rank >= k_count or rank > len(s) or s[rank - 1] <= 0):
            break
        candidate = _with_rank(offsets, u, s, vt, rank, tolerance, basis_levels)
        shapes = rank + sum(1 for r in candidate.residual_rows if len(r))
        if rank and max_shapes is not None and shapes > max_shapes:
            continue
        size = rank * v_count * basis_vertex_bytes + candidate.residual_count() * residual_vertex_bytes
        if best is None or size < best[0]:
            best = (size, candidate)
    assert best is not None  # rank 0 is always a candidate
    return best[1]
