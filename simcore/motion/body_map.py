"""Joint mapping between two skeletons built in one body (a clip carried by the rigged mesh itself).

Both skeletons sit in the same mesh in the same pose, so a target joint can take the source joint whose bones
lie where its own bones lie: the flesh around those bones then turns with the source bone that moves it in
the clip, whatever either hierarchy looks like (IK helpers, feet parented to a floor root, missing pelvis).
`region_mapping` maps every joint so; `fill_by_region` only the joints a name mapping left out, among the
source joints on the hierarchy path between the source joint of the target joint's nearest mapped ancestor
and those of its nearest mapped descendants, so the mapping stays ordered along every chain.

When the clip is the mesh's own and both skins are known, a target joint may only take a source joint that moves
a fair share of its flesh (`flesh_shares`): the nearest bones are not always the ones that move the flesh around
them (a mech's cockpit bound to its body joint, whose bone lies far below it), and a target bone out in such
flesh is otherwise as near the bones of several source joints.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from simcore.skeleton.types import Skeleton, ancestors, is_at_or_below, tree_depths
from simcore.skinning.bones import JointSegments, joint_distances, joint_segments

SAMPLES = (0.25, 0.5, 0.75)  # points along each target bone compared with the source's bones
SHARE_OF_BEST = 0.5  # a source joint moving under this part of what the main one moves of a joint's flesh is ruled out
TIE_BREAK = 1e-6  # weight of the distance to source bone middles, which only decides equal bone distances


def flesh_shares(target_weights: sp.spmatrix, source_weights: sp.spmatrix) -> np.ndarray:
    """(Jt, Js) how much of the flesh each target joint moves each source joint moves: the weights (V, Jt) and
    (V, Js) of one mesh's vertices, multiplied over the vertices."""
    return np.asarray((sp.csr_matrix(target_weights).T @ sp.csc_matrix(source_weights)).todense(), dtype=np.float64)


def _region_cost(source: Skeleton, target: Skeleton, shares: np.ndarray | None = None) -> np.ndarray:
    """(Jt, Js) mean distance from points along each target joint's bones (a joint that owns none: its position) to
    each source joint's bones, plus TIE_BREAK × the mean distance to the middles of those bones. With `shares`
    (`flesh_shares`), a source joint moving under SHARE_OF_BEST as much of the target joint's flesh as the source
    joint moving most costs more than any other (ruled out wherever another is allowed; a target joint that moves
    no flesh keeps every source joint).

    A target bone whose points all lie nearest a source joint's head is exactly as near the source bone ending
    there as the one starting there; which one wins would then follow rounding. The middles' term decides such
    ties for the source bone that lies more towards the target bone, and is too small to reorder any other pair.
    """
    seg = joint_segments(target)
    fractions = np.asarray(SAMPLES)[:, None, None]
    points = (seg.heads[None] + fractions * (seg.tails - seg.heads)[None]).reshape(-1, 3)
    owner = np.tile(seg.owner, len(SAMPLES))
    boneless = np.setdiff1d(np.arange(target.num_joints), seg.owner)  # helpers (JointKind.HELPER): their position
    points, owner = np.concatenate([points, target.positions[boneless]]), np.concatenate([owner, boneless])
    bones = joint_segments(source)
    middles = 0.5 * (bones.heads + bones.tails)
    dist = joint_distances(points, bones, source.num_joints)  # (P, Js)
    dist += TIE_BREAK * joint_distances(points, JointSegments(middles, middles, bones.owner, bones.leaf), source.num_joints)
    total = np.zeros((target.num_joints, source.num_joints))
    np.add.at(total, owner, dist)
    cost = total / np.bincount(owner, minlength=target.num_joints)[:, None]
    if shares is None:
        return cost
    best = shares.max(axis=1, keepdims=True)
    ruled_out = (shares < SHARE_OF_BEST * best) & (best > 0)
    return cost + ruled_out * 1e3 * (1.0 + float(cost.max()))  # after every allowed joint, still nearest first


def _mapped_below(target: Skeleton, mapping: dict[int, int], j: int) -> list[int]:
    """Source joints of the nearest mapped descendants of target joint j."""
    children = target.children()
    out, stack = [], list(children[j])
    while stack:
        c = stack.pop()
        if c in mapping:
            out.append(mapping[c])
        else:
            stack.extend(children[c])
    return out


def fill_by_region(source: Skeleton, target: Skeleton, mapping: dict[int, int], shares: np.ndarray | None = None) -> dict[int, int]:
    """`mapping` (target joint → source joint) with every unmapped target joint that has a candidate (see the
    module docstring) mapped to the candidate whose bones lie nearest its own. Both skeletons in one frame;
    `shares`: see `_region_cost`."""
    cost = _region_cost(source, target, shares)
    out = dict(mapping)
    depth = tree_depths(target.parents)
    order = sorted(range(target.num_joints), key=lambda j: depth[j])  # parents first
    for j in order:
        if j in out:
            continue
        above, p = None, int(target.parents[j])
        while p >= 0 and above is None:
            above, p = out.get(p), int(target.parents[p])
        below = _mapped_below(target, mapping, j)
        candidates = [s for s in range(source.num_joints)
                      if (above is None or is_at_or_below(source.parents, s, above))
                      and all(is_at_or_below(source.parents, d, s) for d in below)]
        if candidates and (above is not None or below):
            out[j] = min(candidates, key=lambda s: cost[j, s])
    return out


def region_mapping(source: Skeleton, target: Skeleton, shares: np.ndarray | None = None) -> dict[int, int]:
    """Target joint → the source joint whose bones lie nearest its own (both skeletons in one body and frame).

    A branching target joint whose branches go down different source branches takes, of the joint where they
    meet and the joints above it (`branch_candidates`), the one whose bones lie nearest its own, when that one
    lies within its reach (its bones no farther from the target joint's, on average, than its farthest child
    is from it): otherwise the branches meet only far away (separate characters under a scene root) and the
    joint keeps the nearest bones. `shares`: see `_region_cost`.
    """
    cost = _region_cost(source, target, shares)
    out = {j: int(np.argmin(cost[j])) for j in range(target.num_joints)}
    children = target.children()
    depth = tree_depths(target.parents)
    for j in sorted(range(target.num_joints), key=lambda k: -depth[k]):  # children first
        candidates = branch_candidates(source.parents, [out[c] for c in children[j]])
        if not candidates or out[j] in candidates:
            continue
        best = min(candidates, key=lambda s: cost[j, s])
        reach = np.linalg.norm(target.positions[children[j]] - target.positions[j], axis=1).max()
        if cost[j, best] <= reach:
            out[j] = best
    return out


def branch_candidates(parents: np.ndarray, below: list[int]) -> list[int]:
    """The source joints a branching target joint may take when its children map to the source joints `below`:
    the joint where the branches going down meet (their lowest common ancestor) and every joint above it.
    A child mapped above another child's joint runs up the source tree (the two skeletons are rooted at
    different places) and does not count. Empty when fewer than two branches go down or they never meet."""
    down = sorted({b for b in below if not any(a != b and is_at_or_below(parents, a, b) for a in below)})
    if len(down) < 2:
        return []
    path = ancestors(parents, down[0])
    for k, a in enumerate(path):
        if all(is_at_or_below(parents, b, a) for b in down[1:]):
            return path[k:]
    return []
