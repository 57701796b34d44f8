"""Split a medial hub where mirror-paired limbs meet into one junction per pair, strung along the body.

Thinning a short, wide trunk (a stocky quadruped, a dragon's chest) gives an X: the front and back legs,
or the wings and the legs, run diagonally through the trunk and meet at one point in its middle, so a
single joint would carry every limb. Rigs hang each limb pair from its own joint on the spine (shoulders,
hips). A hub is split when all its branches are either mirror pairs (left/right limbs, matched across the
body's mirror plane) or lie on that plane (spine, neck, tail), and the pairs leave the trunk at two or more
places along it. Each limb branch starts where it leaves the trunk (its medial radius falls below
LIMB_RADIUS × the hub's); each pair gets a junction at that point's projection on the spine line, and the
spine branches continue from the end junctions. Everything else is left as thinning gave it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simcore.skeleton.graph_simplify import Branch
from simcore.skeleton.mirror import MirrorPlane

LIMB_RADIUS = 0.6  # a limb leaves the trunk where its medial radius drops below this share of the hub's
# (relative to the hub, not graph_simplify.limb_exit's relative-to-the-limb rule: where limbs cross a thick
# trunk, the trunk's width is the reference for where a limb leaves it)
MATCH = 0.5  # mirror partners (and on-plane branches) within this × the hub radius
SAME_JOINT = 0.5  # pairs whose junctions are closer than this × the hub radius along the spine share one


@dataclass
class HubSplit:
    """Joint graph after splitting: `rep`/`merged` gain the new junction keys, `branches` are rewritten, and
    `links` joins the new junctions of each split hub in order along its spine."""

    rep: dict[int, int]
    merged: dict[int, np.ndarray]
    branches: list[Branch]
    links: list[tuple[int, int]]


def split_hubs(rep: dict[int, int], merged: dict[int, np.ndarray], branch_list: list[Branch],
               positions: np.ndarray, radius: np.ndarray, plane: MirrorPlane, first_key: int) -> HubSplit:
    """Split every hub (≥ 4 branches after junction merging) whose branches are mirror pairs or on-plane.

    rep/merged/branch_list: as `merge_junctions` returns them; positions/radius: the medial forest's;
    first_key: an id above every medial node id, for the new junctions. Inputs are not modified.
    """
    out = HubSplit(dict(rep), dict(merged), list(branch_list), [])
    incident: dict[int, list[tuple[int, bool]]] = {}
    for i, b in enumerate(branch_list):
        incident.setdefault(rep[b.start], []).append((i, True))
        incident.setdefault(rep[b.end], []).append((i, False))
    rewritten: set[int] = set()
    for hub, items in sorted(incident.items()):
        if len(items) < 4 or any(i in rewritten for i, _ in items):
            continue
        paths = [branch_list[i].nodes if at_start else branch_list[i].nodes[::-1] for i, at_start in items]
        new = _split(out.merged[hub], float(radius[hub]), paths, positions, radius, plane)
        if new is None:
            continue
        keys = list(range(first_key, first_key + len(new.junctions)))
        first_key += len(keys)
        for key, point in zip(keys, new.junctions):
            out.rep[key] = key
            out.merged[key] = point
        for (i, _), (slot, nodes) in zip(items, new.branches):
            out.branches[i] = Branch(keys[slot], nodes[-1], nodes)
            rewritten.add(i)
        out.links += list(zip(keys[:-1], keys[1:]))
    return out


@dataclass
class _Split:
    junctions: list[np.ndarray]  # along the spine, in order
    branches: list[tuple[int, list[int]]]  # per incident branch: (junction slot, nodes from the hub side)


def _split(centre: np.ndarray, hub_radius: float, paths: list[list[int]], positions: np.ndarray,
           radius: np.ndarray, plane: MirrorPlane) -> _Split | None:
    """New junctions for one hub, or None when its branches are not all mirror pairs or on-plane."""
    starts = [_limb_start(path, radius, hub_radius) for path in paths]
    exits = np.array([positions[path[k]] for path, k in zip(paths, starts)])
    gap = np.linalg.norm(plane.reflect(exits)[:, None] - exits[None], axis=2)
    tolerance = MATCH * hub_radius
    pairs, spine = [], []
    for a in range(len(paths)):
        b = int(np.argmin(gap[a]))
        if gap[a, b] >= tolerance:
            return None
        if b == a:
            spine.append(a)
        elif int(np.argmin(gap[b])) == a and a < b:
            pairs.append((a, b))
    if len(pairs) < 2 or 2 * len(pairs) + len(spine) != len(paths):
        return None
    mids = np.array([(exits[a] + exits[b]) / 2.0 for a, b in pairs])
    along = np.linalg.svd(np.concatenate([mids, exits[spine]]) - centre, full_matrices=False)[2][0]
    t_pair = (mids - centre) @ along
    levels: list[list[int]] = []  # pairs grouped by where they join the spine, in order along it
    for p in np.argsort(t_pair, kind="stable"):
        if levels and t_pair[p] - t_pair[levels[-1][-1]] < SAME_JOINT * hub_radius:
            levels[-1].append(int(p))
        else:
            levels.append([int(p)])
    if len(levels) < 2:  # every pair joins at one point anyway: nothing to split
        return None
    t_level = [float(np.mean(t_pair[level])) for level in levels]
    branches: dict[int, tuple[int, list[int]]] = {}  # incident branch → (junction slot, nodes from the hub side)
    for slot, level in enumerate(levels):
        for p in level:
            for a in pairs[p]:
                branches[a] = (slot, paths[a][starts[a]:])
    for a in spine:  # a spine branch leaves from the end junction on its side, past it
        t_nodes = (positions[paths[a]] - centre) @ along
        slot = len(levels) - 1 if t_nodes[-1] >= 0 else 0
        side = 1.0 if t_nodes[-1] >= 0 else -1.0
        beyond = [n for n, t in zip(paths[a], t_nodes) if side * t > side * t_level[slot]]
        branches[a] = (slot, beyond or paths[a][-1:])
    return _Split([centre + t * along for t in t_level], [branches[a] for a in range(len(paths))])


def _limb_start(path: list[int], radius: np.ndarray, hub_radius: float) -> int:
    """Index along `path` (from the hub) of the first node thinner than LIMB_RADIUS × the hub's radius."""
    thin = np.flatnonzero(radius[path[1:]] < LIMB_RADIUS * hub_radius)
    return int(thin[0]) + 1 if len(thin) else len(path) - 1
