"""Structural joint matching for skeletons whose names say nothing (creatures, predicted skeletons).

Both skeletons are normalised (joint bounding box centred, largest side 1). End joints (leaves) are paired by rest
position with the Hungarian method, under the quarter-turn about +Y that fits best (characters face a
world axis). Branch joints are paired as the lowest common ancestors of paired leaves, roots with roots,
and the joints between two paired anchors of a chain (spine, limb, tail, neck) by arc-length fraction.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.spatial.transform import Rotation

from simcore.skeleton.types import Skeleton, ancestors

TURN_MARGIN = 0.8  # another facing must beat the unturned fit by this factor
MAX_LEAF_DISTANCE = 0.35  # in bounding-box sizes: farther leaves are left unpaired


def normalised_rest(skeleton: Skeleton) -> np.ndarray:
    """(J, 3) rest positions centred on the joints' bounding box and divided by its largest side; the box,
    unlike the root, sits at the same place for two rigs of one body (roots may be at the hips or the floor)."""
    lo, hi = skeleton.positions.min(axis=0), skeleton.positions.max(axis=0)
    size = float((hi - lo).max()) or 1.0
    return (skeleton.positions - (lo + hi) / 2) / size


def branch_root(skeleton: Skeleton) -> int:
    """The first joint below the root with several children (a static root chain above the hips is skipped)."""
    children = skeleton.children()
    if max(len(c) for c in children) < 2:
        return 0  # a single chain (tail, two-bone cylinder): its root is the place to anchor
    j = 0
    while len(children[j]) == 1:
        j = children[j][0]
    return j


def quarter_turn(k: int) -> np.ndarray:
    """(3, 3) rotation by k·90° about +Y."""
    return Rotation.from_rotvec([0.0, k * np.pi / 2, 0.0]).as_matrix()


def _lca(parents: np.ndarray, a: int, b: int) -> int:
    up = set(ancestors(parents, a))
    return next(j for j in ancestors(parents, b) if j in up)


def _leaves(skeleton: Skeleton) -> np.ndarray:
    has_child = np.zeros(skeleton.num_joints, bool)
    has_child[skeleton.parents[skeleton.parents >= 0]] = True
    return np.flatnonzero(~has_child)


def pair_leaves(source: Skeleton, target: Skeleton, turns: int | None = None) -> tuple[list[tuple[int, int]], int]:
    """([(target leaf, source leaf)], quarter turns k applied to the source) of the best leaf pairing; `turns`
    fixes k (skeletons known to share a frame), None tries the four."""
    ls, lt = _leaves(source), _leaves(target)
    ps, pt = normalised_rest(source), normalised_rest(target)
    results = []
    for k in range(4) if turns is None else [turns]:
        rotated = ps[ls] @ quarter_turn(k).T
        cost = np.linalg.norm(pt[lt][:, None, :] - rotated[None, :, :], axis=2)
        rows, cols = linear_sum_assignment(cost)
        keep = cost[rows, cols] <= MAX_LEAF_DISTANCE
        # Unpaired leaves cost the threshold, so a turn that pairs more leaves wins.
        total = float(cost[rows, cols][keep].sum() + MAX_LEAF_DISTANCE * (len(lt) - keep.sum()))
        results.append((total, [(int(lt[r]), int(ls[c])) for r, c in zip(rows[keep], cols[keep])], k))
    best = min(results, key=lambda r: r[0])
    if best[0] > TURN_MARGIN * results[0][0]:
        best = results[0]  # mirror-symmetric bodies fit a half turn almost as well: keep the rigs as given
    return best[1], best[2]


def _arc_fraction(positions: np.ndarray, chain: list[int]) -> np.ndarray:
    """(len(chain),) cumulative bone length along a root-ward-first chain, 0 at its start, 1 at its end."""
    seg = np.linalg.norm(np.diff(positions[chain], axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    return cum / cum[-1] if cum[-1] > 0 else np.linspace(0.0, 1.0, len(chain))


def chain_mapping(source: Skeleton, target: Skeleton, turns: int | None = None) -> tuple[dict[int, int], int]:
    """(target joint → source joint, quarter turns about +Y that align the source to the target); `turns` fixes
    the facing (None: the best fit of the four)."""
    pairs, turns = pair_leaves(source, target, turns)
    mapping: dict[int, int] = {branch_root(target): branch_root(source)}
    for t_leaf, s_leaf in pairs:
        mapping[t_leaf] = s_leaf
    for a in range(len(pairs)):  # branch points: common ancestors of paired leaves
        for b in range(a + 1, len(pairs)):
            t_lca = _lca(target.parents, pairs[a][0], pairs[b][0])
            s_lca = _lca(source.parents, pairs[a][1], pairs[b][1])
            mapping.setdefault(t_lca, s_lca)
    ps, pt = normalised_rest(source), normalised_rest(target)
    for t_leaf, s_leaf in pairs:  # interior joints between consecutive anchors of each chain
        t_path = ancestors(target.parents, t_leaf)[::-1]
        s_path = ancestors(source.parents, s_leaf)[::-1]
        s_pos = {j: k for k, j in enumerate(s_path)}
        anchors = [k for k, j in enumerate(t_path) if j in mapping and mapping[j] in s_pos]
        for a, b in zip(anchors[:-1], anchors[1:]):
            t_seg = t_path[a:b + 1]
            s_seg = s_path[s_pos[mapping[t_path[a]]]:s_pos[mapping[t_path[b]]] + 1]
            if len(t_seg) <= 2 or len(s_seg) <= 2:
                continue
            tf, sf = _arc_fraction(pt, t_seg), _arc_fraction(ps, s_seg)
            for k in range(1, len(t_seg) - 1):
                inner = int(np.argmin(np.abs(sf[1:-1] - tf[k]))) + 1
                mapping.setdefault(t_seg[k], s_seg[inner])
    return mapping, turns
