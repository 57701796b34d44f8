"""The array helpers against the numpy calls they replace."""

from __future__ import annotations

import numpy as np
import pytest

from simcore.arrays import smallest_k, unique_ints


@pytest.mark.parametrize("values", [
    np.random.default_rng(0).integers(-50, 50, 1000),
    np.random.default_rng(1).integers(0, 10**12, (300, 3)),
    np.zeros(0, np.int64),
    np.array([[7, 7], [7, 7]], np.int32),
])
def test_unique_ints_matches_numpy(values: np.ndarray) -> None:
    got = unique_ints(values)
    np.testing.assert_array_equal(got, np.unique(values))
    assert got.dtype == values.dtype


@pytest.mark.parametrize("seed", range(6))
def test_smallest_k_orders_as_a_stable_argsort(seed: int) -> None:
    """Ties included (few distinct values, and rows where the k-th value repeats past k), as the skinning
    features' unreachable joints, which all read one far distance, need."""
    rng = np.random.default_rng(seed)
    values = rng.integers(0, 4, (200, 20)).astype(float) if seed % 2 else rng.random((200, 20))
    for k in (1, 5, 19, 20, 25):
        np.testing.assert_array_equal(smallest_k(values, k), np.argsort(values, axis=1, kind="stable")[:, :k])
