"""unique_ints against np.unique."""

from __future__ import annotations

import numpy as np
import pytest

from simcore.arrays import unique_ints


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
