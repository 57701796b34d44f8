"""Extra limbs for a fitted humanoid: wings, tails, long ears — medial branches the Mixamo template leaves out.

After the template fit, every tip of the biped's medial tree that is not the head, a hand or a foot is traced
back to the first node already explained (the head-to-limb paths, or an extra limb taken before it). A branch
at least MIN_LENGTH × the character's height long becomes a SPRING chain (UniRig's secondary-chain section):
joints at its turning points and every `spacing`, the tip pulled in like the geometric method's, hung under the
template (or earlier extra) joint nearest to where it branches off. Shorter tips are surface bumps (hair
tufts, coat tails, thumbs that survived pruning) and are ignored.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simcore.skeleton.geometric import GeometricParams
from simcore.skeleton.graph_simplify import branch_joints, path_length

MIN_LENGTH = 0.35  # × height: shorter free branches are not limbs (wings and tails run longer; spikes and horns are shorter)
CHAIN = GeometricParams()  # joint spacing, turning tolerance and tip pull: as the geometric method


@dataclass
class ExtraChain:
    """One extra limb: positions (K, 3) from its root to its tip; `parent` is the index of the joint it hangs
    from in the joint list it is appended to (template joints first, then earlier chains)."""

    positions: np.ndarray
    parent: int


def extra_limbs(pos: np.ndarray, radius: np.ndarray, adjacency: list[list[int]], nodes: np.ndarray,
                parent: dict[int, int], template_tips: list[int], joints: np.ndarray, height: float,
                scale: float) -> list[ExtraChain]:
    """Chains for the medial tree's unexplained long branches.

    pos (N, 3), radius (N,): medial nodes; adjacency: node neighbour lists; nodes: ids of the biped's tree;
    parent: node → parent with the tree rooted at the head tip; template_tips: the head, hand and foot tips;
    joints: (J, 3) the template joints placed so far. Chains come longest first.
    """
    explained: set[int] = set()
    for tip in template_tips:
        n = tip
        while n >= 0:
            explained.add(n)
            n = parent[n]
    candidates = []
    for leaf in (int(n) for n in nodes if len(adjacency[n]) == 1 and int(n) not in explained):
        path = [leaf]
        while path[-1] not in explained and parent[path[-1]] >= 0:
            path.append(parent[path[-1]])
        candidates.append((path_length(pos, path), leaf))
    chains: list[ExtraChain] = []
    anchors = [np.asarray(joints, np.float64)]
    for _, leaf in sorted(candidates, key=lambda c: (-c[0], c[1])):
        path = [leaf]
        while path[-1] not in explained and parent[path[-1]] >= 0:
            path.append(parent[path[-1]])
        if path_length(pos, path) < MIN_LENGTH * height:
            continue
        pts = pos[path[::-1]]  # branch point → tip
        inner = branch_joints(pts, radius[path[::-1]], CHAIN.turn_ratio, CHAIN.turn_min * scale, CHAIN.spacing * scale)
        keep = [i for i in inner if np.linalg.norm(pts[i] - pts[0]) > radius[path[-1]]]  # outside the body
        chain = pts[keep + [len(pts) - 1]].copy()
        if len(chain) >= 2:
            chain[-1] += CHAIN.tip_pull * (chain[-2] - chain[-1])
        placed = np.concatenate(anchors)
        hang = int(np.argmin(np.linalg.norm(placed - pts[0], axis=1)))
        chains.append(ExtraChain(chain, hang))
        anchors.append(chain)
        explained.update(path)
    return chains
