"""The vectorised voxel shortest paths against scipy's Dijkstra on the same 26-neighbour graph."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra

from simcore.geometry.voxel_paths import VoxelPaths

PITCH = 0.1


@pytest.fixture(scope="module")
def u_shape() -> np.ndarray:
    """A U of voxels (two 12-long arms joined at the bottom): the arm tips are far apart through the solid."""
    occ = np.zeros((9, 14, 3), bool)
    occ[0:3, :, :] = True
    occ[6:9, :, :] = True
    occ[:, 0:3, :] = True
    return occ


def _reference(occ: np.ndarray, sources: list[tuple[int, int, float]], count: int) -> np.ndarray:
    """(n, count) distances by scipy: an explicit graph with one super-source node per search."""
    ijk = np.argwhere(occ)
    index = {tuple(p): i for i, p in enumerate(ijk)}
    rows: list[int] = []
    cols: list[int] = []
    lengths: list[float] = []
    for i, p in enumerate(ijk):
        for o in itertools.product((-1, 0, 1), repeat=3):
            q = index.get(tuple(p + o))
            if o != (0, 0, 0) and q is not None:
                rows.append(i)
                cols.append(q)
                lengths.append(float(np.linalg.norm(o)) * PITCH)
    n = len(ijk)
    for group, voxel, length in sources:
        rows.append(n + group)
        cols.append(voxel)
        lengths.append(length + 1e-12)
    graph = sp.csr_matrix((lengths, (rows, cols)), shape=(n + count, n + count))
    return dijkstra(graph, directed=True, indices=np.arange(n, n + count))[:, :n].T


def test_unbounded_searches_match_scipy(u_shape: np.ndarray) -> None:
    paths = VoxelPaths(u_shape, PITCH)
    tip_a = paths.ids[1, 13, 1]
    tip_b = paths.ids[7, 13, 1]
    corner = paths.ids[1, 1, 1]
    sources = [(0, tip_a, 0.0), (1, tip_b, 0.02), (1, corner, 0.05), (2, corner, 0.0)]
    group, voxel, length = (np.array(c) for c in zip(*sources))
    got = paths.distances(group, voxel, length, 3)
    want = _reference(u_shape, sources, 3)
    assert got.shape == (len(paths.ijk), 3)
    np.testing.assert_allclose(got, want, atol=1e-9)
    # Through the solid, not across the gap: tip to tip goes down one arm and up the other.
    assert got[tip_b, 0] > 2 * 11 * PITCH


def test_bound_stops_a_search_and_keeps_what_it_reaches_exact(u_shape: np.ndarray) -> None:
    paths = VoxelPaths(u_shape, PITCH)
    tip_a = paths.ids[1, 13, 1]
    exact = paths.distances(np.array([0]), np.array([tip_a]), np.array([0.0]), 1)[:, 0]
    bound = np.full(len(paths.ijk), 0.75)
    got = paths.distances(np.array([0]), np.array([tip_a]), np.array([0.0]), 1, bound)[:, 0]
    inside = exact <= 0.75
    assert 0 < inside.sum() < len(exact)
    np.testing.assert_allclose(got[inside], exact[inside])
    assert np.all(np.isinf(got[~inside]))


def test_sources_that_start_buckets_apart_match_scipy(u_shape: np.ndarray) -> None:
    # Starting lengths of several pitches put sources in later buckets than the first ones they compete with.
    paths = VoxelPaths(u_shape, PITCH)
    tip_a, tip_b, corner = paths.ids[1, 13, 1], paths.ids[7, 13, 1], paths.ids[1, 1, 1]
    sources = [(0, tip_a, 0.37), (0, corner, 0.0), (0, tip_b, 0.9), (1, tip_b, 0.25), (1, paths.ids[7, 10, 1], 0.05)]
    group, voxel, length = (np.array(c) for c in zip(*sources))
    got = paths.distances(group, voxel, length, 2)
    np.testing.assert_allclose(got, _reference(u_shape, sources, 2), atol=1e-9)


def test_many_small_batches_give_the_same_distances(u_shape: np.ndarray, monkeypatch: pytest.MonkeyPatch) -> None:
    # A rig of many joints runs its searches in several memory-bounded batches; the result must not change.
    paths = VoxelPaths(u_shape, PITCH)
    rng = np.random.default_rng(3)
    sources = [(g, int(v), float(d)) for g, v, d in zip(range(7), rng.choice(len(paths.ijk), 7, replace=False), rng.uniform(0, 0.2, 7))]
    group, voxel, length = (np.array(c) for c in zip(*sources))
    whole = paths.distances(group, voxel, length, 7)
    monkeypatch.setattr("simcore.geometry.voxel_paths.BATCH_PAIRS", 2 * len(paths.ijk))  # 4 batches
    np.testing.assert_array_equal(paths.distances(group, voxel, length, 7), whole)
    np.testing.assert_allclose(whole, _reference(u_shape, sources, 7), atol=1e-9)
