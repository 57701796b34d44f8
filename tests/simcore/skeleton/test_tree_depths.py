"""tree_depths counts each joint's ancestors, whatever order the joints are listed in."""

from __future__ import annotations

import numpy as np
import pytest

from simcore.errors import InvalidInput
from simcore.skeleton.types import tree_depths


def _walked(parents: np.ndarray) -> list[int]:
    """Ancestors counted by walking up from every joint."""
    out = []
    for j in range(len(parents)):
        d = 0
        while parents[j] >= 0:
            j, d = int(parents[j]), d + 1
        out.append(d)
    return out


def test_tree_depths_count_ancestors_in_any_order() -> None:
    rng = np.random.default_rng(4)
    ordered = np.array([-1] + [int(rng.integers(0, j)) for j in range(1, 40)])
    depth = tree_depths(ordered)
    assert depth.dtype == np.int64 and depth.tolist() == _walked(ordered)
    shuffle = rng.permutation(40)
    rank = np.argsort(shuffle)  # joint shuffle[k] is listed at k
    listed = np.where(ordered[shuffle] >= 0, rank[np.maximum(ordered[shuffle], 0)], -1)
    assert tree_depths(listed).tolist() == depth[shuffle].tolist() == _walked(listed)


def test_tree_depths_of_several_roots_and_a_cycle() -> None:
    assert tree_depths(np.array([2, -1, -1, 0, 1])).tolist() == [1, 0, 0, 2, 1]
    with pytest.raises(InvalidInput, match="cycle"):
        tree_depths(np.array([-1, 2, 1]))
