"""Shortest paths through the occupied voxels of a grid (26 neighbours, Euclidean steps), compiled and GIL-free.

Each search (one per joint, or one from all joints at once) may be bounded per voxel: it settles a voxel only
while its distance there is within that voxel's `bound`. In geodesic binding the bound is a multiple of the
voxel's distance to its nearest joint, beyond which a joint's weight is negligible, so each joint explores its
own neighbourhood instead of the whole solid (3–8× fewer voxel visits on the dev rigs). The searches walk the
grid directly, with no graph built. Numba compiles the loop once per machine (cached on disk); searches are
split across threads, which run in parallel because the loop holds no GIL.
"""

from __future__ import annotations

import heapq
import itertools
from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np

from simcore.cores import usable_cores

_OFFSETS = np.array([o for o in itertools.product((-1, 0, 1), repeat=3) if o != (0, 0, 0)], dtype=np.int64)


@numba.njit(cache=True, nogil=True)
def _search(ids, flat, delta, steps, src_ptr, src_voxel, src_length, bound, searches, out):  # pragma: no cover - compiled
    """Dijkstra (binary heap, lazy deletion) for each search in `searches`, writing out[search, voxel]."""
    for s in searches:
        dist = out[s]
        heap = [(0.0, np.int64(0))]
        heap.pop()
        for k in range(src_ptr[s], src_ptr[s + 1]):
            v, d = src_voxel[k], src_length[k]
            if d < dist[v] and d <= bound[v]:
                dist[v] = d
                heapq.heappush(heap, (d, v))
        while heap:
            d, v = heapq.heappop(heap)
            if d > dist[v]:
                continue
            for k in range(len(delta)):
                u = ids[flat[v] + delta[k]]
                if u < 0:
                    continue
                nd = d + steps[k]
                if nd < dist[u] and nd <= bound[u]:
                    dist[u] = nd
                    heapq.heappush(heap, (nd, u))


class VoxelPaths:
    """The occupied voxels of a boolean grid and shortest paths between them.

    ijk: (n, 3) int64 occupied voxel indices (C order); ids: (X, Y, Z) int64 voxel id per cell, -1 = empty.
    """

    def __init__(self, occupancy: np.ndarray, pitch: float):
        self.ijk = np.argwhere(occupancy)
        padded = np.full(np.asarray(occupancy.shape) + 2, -1, dtype=np.int64)  # an empty layer: no wrap-around
        padded[tuple((self.ijk + 1).T)] = np.arange(len(self.ijk))
        self.ids = padded[1:-1, 1:-1, 1:-1]
        self._ids_flat = padded.ravel()
        self._flat = np.ravel_multi_index(tuple((self.ijk + 1).T), padded.shape)
        self._delta = np.ravel_multi_index(tuple((_OFFSETS + 1).T), padded.shape) - np.ravel_multi_index((1, 1, 1), padded.shape)
        self._steps = np.linalg.norm(_OFFSETS, axis=1) * pitch

    def distances(self, group: np.ndarray, voxel: np.ndarray, length: np.ndarray, count: int, bound: np.ndarray | None = None) -> np.ndarray:
        """(n, count) float64 shortest distances from each group of sources; inf where unreached or past `bound`.

        group/voxel/length: one row per source (search index in [0, count), voxel id, starting distance ≥ 0);
        bound: (n,) per-voxel limit, None = unbounded.
        """
        n = len(self.ijk)
        order = np.argsort(group, kind="stable")
        src_ptr = np.concatenate([[0], np.cumsum(np.bincount(group, minlength=count))]).astype(np.int64)
        out = np.full((count, n), np.inf)
        limit = np.full(n, np.inf) if bound is None else np.asarray(bound, dtype=np.float64)
        args = (self._ids_flat, self._flat, self._delta, self._steps, src_ptr, voxel[order].astype(np.int64),
                length[order].astype(np.float64), limit)
        threads = max(1, min(usable_cores(), count))
        with ThreadPoolExecutor(max_workers=threads) as pool:  # searches interleaved: big and small ones mixed
            list(pool.map(lambda t: _search(*args, np.arange(t, count, threads, dtype=np.int64), out), range(threads)))
        return out.T
