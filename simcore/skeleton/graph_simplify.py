"""Medial forest → a sparse joint graph: prune spurs, merge close junctions, keep turning points.

Works on node-level adjacency lists (a forest over medial voxels). A *branch* is a maximal path whose
interior nodes have degree 2; its ends are *key* nodes (endpoints, junctions). Lengths are metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simcore.skeleton.mirror import MirrorPlane


@dataclass
class Branch:
    """A polyline between two key nodes.

    nodes: node ids from `start` to `end` inclusive (medial-forest ids).
    """

    start: int
    end: int
    nodes: list[int]


def _walk(adjacency: list[list[int]], start: int, first: int) -> list[int]:
    """Node path from `start` through `first` until a node whose degree is not 2."""
    path = [start, first]
    prev, cur = start, first
    while len(adjacency[cur]) == 2:
        nxt = adjacency[cur][0] if adjacency[cur][1] == prev else adjacency[cur][1]
        path.append(nxt)
        prev, cur = cur, nxt
    return path


def path_length(positions: np.ndarray, path: list[int]) -> float:
    """Polyline length of `path` (node ids) in metres."""
    if len(path) < 2:
        return 0.0
    p = positions[path]
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())


def _remove_nodes(adjacency: list[list[int]], nodes: list[int]) -> None:
    gone = set(nodes)
    for n in nodes:
        for m in adjacency[n]:
            if m not in gone:
                adjacency[m].remove(n)
        adjacency[n] = []


def prune_spurs(adjacency: list[list[int]], positions: np.ndarray, radius: np.ndarray, ratio: float,
                min_length: float, plane: MirrorPlane | None = None, slender: float = np.inf) -> list[int]:
    """Remove leaf branches shorter than `ratio` × the junction's radius + `min_length` (in place).

    Spurs come from surface bumps: a real limb is longer than the thickness of what it hangs off. Each pass
    removes at most one spur per junction (the shortest), so two real short branches cannot vanish together.
    With the body's mirror `plane`, two spurs of one junction that are each other's mirror image are decided
    together: kept when both are slender (longer than `slender` × their median radius: fins, ears, horns; the
    default keeps none), else removed together. One at a time, the shorter would go and its twin would stay on as
    the junction's continuation (a fish with one pectoral fin). Returns the ids of the removed nodes.
    """
    removed: list[int] = []
    twins_kept: set[int] = set()  # leaves of slender mirror twins
    while True:
        spurs: dict[int, list[tuple[float, list[int]]]] = {}  # junction → (length, leaf → junction path)
        for leaf in range(len(adjacency)):
            if len(adjacency[leaf]) != 1 or leaf in twins_kept:
                continue
            path = _walk(adjacency, leaf, adjacency[leaf][0])
            end = path[-1]
            length = path_length(positions, path)
            if len(adjacency[end]) >= 3 and length < ratio * radius[end] + min_length:
                spurs.setdefault(end, []).append((length, path))
        if not spurs:
            return removed
        for end in sorted(spurs):
            if len(adjacency[end]) < 3:  # an earlier removal this pass may have lowered its degree
                continue
            twins = _twin_spurs(spurs[end], positions, float(radius[end]), plane)
            if twins is None:
                doomed = [min(spurs[end], key=lambda spur: spur[0])[1]]
            elif all(length >= slender * float(np.median(radius[path])) for length, path in twins):
                twins_kept.update(path[0] for _, path in twins)
                continue
            else:
                doomed = [path for _, path in twins]
            for path in doomed:
                _remove_nodes(adjacency, path[:-1])
                removed += path[:-1]


def _twin_spurs(spurs: list[tuple[float, list[int]]], positions: np.ndarray, tolerance: float,
                plane: MirrorPlane | None) -> list[tuple[float, list[int]]] | None:
    """The first two of one junction's `spurs` whose leaves are mirror images across `plane` (within `tolerance`)
    and not one leaf on the plane, or None."""
    if plane is None or len(spurs) < 2:
        return None
    leaves = positions[[path[0] for _, path in spurs]]
    mirrored = plane.reflect(leaves)
    for a in range(len(spurs)):
        for b in range(a + 1, len(spurs)):
            if (np.linalg.norm(mirrored[a] - leaves[b]) < tolerance
                    and np.linalg.norm(leaves[a] - leaves[b]) >= tolerance):
                return [spurs[a], spurs[b]]
    return None


def branches(adjacency: list[list[int]], nodes: np.ndarray) -> tuple[list[int], list[Branch]]:
    """Key nodes (degree != 2) among `nodes` (ids of one tree) and the branches between them.

    A tree that is a single node gives that node and no branches.
    """
    keys = sorted(int(n) for n in nodes if len(adjacency[n]) != 2)
    if not keys and len(nodes):
        keys = [int(min(nodes))]  # unreachable for a tree, kept for safety with a degenerate cycle
    out: list[Branch] = []
    for k in keys:
        for first in adjacency[k]:
            path = _walk(adjacency, k, first)
            if (path[0], path[1]) <= (path[-1], path[-2]):  # each branch once, from its smaller end
                out.append(Branch(path[0], path[-1], path))
    return keys, out


def merge_junctions(keys: list[int], branch_list: list[Branch], adjacency: list[list[int]], positions: np.ndarray,
                    radius: np.ndarray, ratio: float) -> tuple[dict[int, int], dict[int, np.ndarray], list[Branch]]:
    """Contract junction-to-junction branches shorter than `ratio` × the larger junction radius.

    Returns (key → representative key, representative → merged position (3,), remaining branches). The merged
    position is the node of the contracted cluster nearest to the cluster's mean, so it stays inside the solid.
    """
    parent = {k: k for k in keys}

    def find(k: int) -> int:
        while parent[k] != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    members: dict[int, list[int]] = {k: [k] for k in keys}
    kept: list[Branch] = []
    for b in sorted(branch_list, key=lambda b: path_length(positions, b.nodes)):
        junctions = len(adjacency[b.start]) >= 3 and len(adjacency[b.end]) >= 3
        length = path_length(positions, b.nodes)
        ra, rb = find(b.start), find(b.end)
        if junctions and ra != rb and length < ratio * max(radius[b.start], radius[b.end]):
            lo, hi = min(ra, rb), max(ra, rb)
            parent[hi] = lo
            members[lo] = members[lo] + members.pop(hi) + b.nodes[1:-1]
        else:
            kept.append(b)
    rep = {k: find(k) for k in keys}
    merged: dict[int, np.ndarray] = {}
    for r, nodes in members.items():
        cluster = positions[nodes]
        mean = cluster.mean(axis=0)
        merged[r] = cluster[int(np.argmin(np.linalg.norm(cluster - mean, axis=1)))]
    remaining = [b for b in kept if rep[b.start] != rep[b.end]]
    return rep, merged, remaining


def douglas_peucker(points: np.ndarray, tolerance: float) -> list[int]:
    """Indices of the polyline's turning points (ends included) whose removal would move the line > tolerance."""
    keep = {0, len(points) - 1}
    stack = [(0, len(points) - 1)]
    while stack:
        a, b = stack.pop()
        if b - a < 2:
            continue
        seg = points[b] - points[a]
        rel = points[a + 1:b] - points[a]
        denom = float(seg @ seg)
        if denom < 1e-18:
            dist = np.linalg.norm(rel, axis=1)
        else:
            t = np.clip(rel @ seg / denom, 0.0, 1.0)
            dist = np.linalg.norm(rel - t[:, None] * seg, axis=1)
        i = int(np.argmax(dist))
        if dist[i] > tolerance:
            keep.add(a + 1 + i)
            stack += [(a, a + 1 + i), (a + 1 + i, b)]
    return sorted(keep)


def branch_joints(points: np.ndarray, radius: np.ndarray, tolerance_ratio: float, min_tolerance: float,
                  spacing: float) -> list[int]:
    """Interior joint indices on one branch polyline `points` (M, 3), ends excluded.

    Turning points (Douglas-Peucker, tolerance = max(`tolerance_ratio` × median radius, `min_tolerance`)) come
    first; then every stretch longer than `spacing` is split evenly by arc length, so a straight limb still gets
    elbow/knee-like joints. Returned indices point at polyline nodes (medial voxels, inside the solid).
    """
    if len(points) < 3:
        return []
    tol = max(tolerance_ratio * float(np.median(radius)), min_tolerance)
    turning = douglas_peucker(points, tol)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    out: list[int] = []
    for a, b in zip(turning[:-1], turning[1:]):
        n = int(np.floor((arc[b] - arc[a]) / spacing + 0.5)) if spacing > 0 else 0
        for k in range(1, n):
            target = arc[a] + (arc[b] - arc[a]) * k / n
            out.append(int(np.clip(np.searchsorted(arc, target), a + 1, b - 1)))
        if b != len(points) - 1:
            out.append(b)
    return sorted(set(i for i in out if 0 < i < len(points) - 1))


def limb_exit(radius: np.ndarray, ratio: float) -> int:
    """Index along a limb's medial path (body → tip, ball radii `radius`) where it leaves the body: the first node
    whose radius is down to `ratio` × the limb's own (the median over the middle half of the path); 0 when the
    path starts outside any body."""
    own = float(np.median(radius[len(radius) // 4: max(3 * len(radius) // 4, len(radius) // 4 + 1)]))
    return int(np.argmax(radius <= ratio * own))


def rooted_parents(adjacency: list[list[int]], root: int) -> dict[int, int]:
    """Breadth-first parent of every node reachable from `root` (root → -1)."""
    parent = {root: -1}
    queue = [root]
    for n in queue:
        for m in adjacency[n]:
            if m not in parent:
                parent[m] = n
                queue.append(m)
    return parent


def point_at_fraction(points: np.ndarray, fraction: float) -> np.ndarray:
    """(3,) point at `fraction` (0..1) of the polyline `points` (M, 3) by arc length."""
    seg = np.linalg.norm(np.diff(points, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    if len(points) < 2 or arc[-1] <= 0:
        return points[0].copy()
    t = float(np.clip(fraction, 0.0, 1.0)) * arc[-1]
    i = int(np.clip(np.searchsorted(arc, t) - 1, 0, len(seg) - 1))
    return points[i] + (t - arc[i]) / max(seg[i], 1e-12) * (points[i + 1] - points[i])
