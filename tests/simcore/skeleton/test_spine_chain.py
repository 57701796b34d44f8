"""A short torso keeps only the spine joints whose bones are long enough, and one at least."""

from __future__ import annotations

import numpy as np

from simcore.skeleton.spine_chain import kept_spine

# Hips → Neck along +y, the template's spine joints at 0.21, 0.435 and 0.67 of the way (Mixamo characters).
FRACTIONS = np.array([0.0, 0.21, 0.435, 0.67, 1.0])


def chain(length: float) -> np.ndarray:
    return np.c_[np.zeros(5), FRACTIONS * length, np.zeros(5)]


def test_a_long_torso_keeps_all_three():
    assert kept_spine(chain(0.5), min_bone=0.01) == (0, 1, 2)


def test_a_short_torso_keeps_the_layouts_whose_shortest_bone_is_longest():
    # length 0.045: Hips → Spine (0.21 × 0.045 = 0.0095) is too short; Spine1 and Spine2 leave bones of 0.0196,
    # 0.0106 and 0.0149.
    assert kept_spine(chain(0.045), min_bone=0.01) == (1, 2)
    assert kept_spine(chain(0.03), min_bone=0.01) == (1,)  # Spine1 alone halves the torso best
    assert kept_spine(chain(0.015), min_bone=0.01) == (1,)  # one at least, where the torso's motion goes


def test_every_kept_bone_is_at_least_the_minimum():
    for length in np.linspace(0.005, 0.2, 40):
        points = chain(length)
        kept = kept_spine(points, min_bone=0.01)
        bones = np.diff(points[[0, *(i + 1 for i in kept), 4]], axis=0)
        assert len(kept) == 1 or np.linalg.norm(bones, axis=1).min() >= 0.01
