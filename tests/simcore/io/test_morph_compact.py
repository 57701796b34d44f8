"""Compact morph offsets: every vertex within the tolerance, a low-rank clip stored as a basis, caps kept."""

import numpy as np

from simcore.io.morph_compact import compact_offsets


def _clip(keys: int = 40, verts: int = 300, rank: int = 3, seed: int = 0) -> np.ndarray:
    """(K, V, 3) offsets of rank `rank` plus a few large sparse spikes the basis cannot hold."""
    rng = np.random.default_rng(seed)
    offsets = np.einsum("kr,rva->kva", rng.normal(size=(keys, rank)), rng.normal(size=(rank, verts, 3)) * 0.01)
    offsets[rng.integers(keys, size=5), rng.integers(verts, size=5)] += 0.05
    return offsets


def _worst(compact, offsets: np.ndarray) -> float:
    return max(float(np.linalg.norm(compact.reconstruct(k) - offsets[k], axis=1).max()) for k in range(len(offsets)))


def test_low_rank_offsets_become_a_basis_within_the_tolerance():
    offsets, tol = _clip(), 1e-4
    compact = compact_offsets(offsets, tol, 4.0, 5.0)
    assert 0 < compact.rank < len(offsets)
    assert compact.residual_count() < 0.05 * offsets.shape[0] * offsets.shape[1]  # the spikes, not every vertex
    worst = _worst(compact, offsets)
    assert worst <= tol * (1 + 1e-6) and abs(worst - compact.max_error) < 1e-6


def test_quantized_basis_and_shape_cap_keep_the_tolerance():
    offsets, tol = _clip(), 1e-4
    compact = compact_offsets(offsets, tol, 4.0, 5.0, basis_levels=127, max_shapes=len(offsets))
    assert compact.rank + sum(1 for r in compact.residual_rows if len(r)) <= len(offsets)
    assert _worst(compact, offsets) <= tol * (1 + 1e-5)


def test_zero_keys_give_the_empty_form():
    compact = compact_offsets(np.zeros((0, 300, 3)), 1e-4, 4.0, 5.0, basis_levels=127, max_shapes=8)
    assert compact.rank == 0 and compact.basis.shape == (0, 300, 3) and compact.coefficients.shape == (0, 0)
    assert compact.residual_rows == [] and compact.residual_values == [] and compact.residual_count() == 0
    assert compact.max_error == 0.0 and compact.tolerance == 1e-4
