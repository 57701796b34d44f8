"""How many spine joints a humanoid's torso carries.

The Mixamo template puts three (Spine, Spine1, Spine2) between Hips and Neck. On a short torso (a chibi's, under
a big head) its bones come out shorter than `SHORT_BONE` × the mesh's size: joints nearly in one place, which an
animator cannot pick apart and `candidate_score`'s `stacked` term counts against the whole candidate. Such a torso
keeps the most spine joints whose bones are all long enough (among equal counts, the layout whose shortest bone is
the longest), renamed Spine, Spine1 … in order, as Mixamo's own lighter skeletons name them. It keeps one at
least, even with short bones: a clip's spine motion needs a joint between Hips and Neck to go to, or the torso
stretches where the artist's rig bends it.
"""

from __future__ import annotations

from itertools import combinations

import numpy as np

SPINE: tuple[str, ...] = ("Spine", "Spine1", "Spine2")


def _shortest_bone(chain: np.ndarray, kept: tuple[int, ...]) -> float:
    points = chain[[0, *(i + 1 for i in kept), len(chain) - 1]]
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).min())


def kept_spine(chain: np.ndarray, min_bone: float) -> tuple[int, ...]:
    """Indices into SPINE of the spine joints to keep (ascending).

    chain: (5, 3) positions of Hips, Spine, Spine1, Spine2, Neck; min_bone: the shortest bone allowed (metres).
    All three when every bone is long enough; one at least, the one that halves the torso best.
    """
    chain = np.asarray(chain, dtype=np.float64)
    for count in range(len(SPINE), 0, -1):
        best = max(combinations(range(len(SPINE)), count), key=lambda kept: _shortest_bone(chain, kept))
        if _shortest_bone(chain, best) >= min_bone:
            return best
    return best  # the single joint that halves the torso best, short bones and all
