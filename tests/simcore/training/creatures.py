"""A generated character with artist-like weights for the training tests."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from simcore.geometry.capsule_creatures import quadruped
from simcore.training.skin_samples import Character


def capsule_dog() -> Character:
    """The capsule dog, each capsule bound to the joint its bone starts at (what the artist of such a toy would do)."""
    vertices, faces, skeleton = quadruped(count=8)
    per = len(vertices) // len(skeleton.bones())
    owner = np.repeat(skeleton.bones()[:, 0], per)
    weights = sp.csr_matrix((np.ones(len(vertices)), (np.arange(len(vertices)), owner)), shape=(len(vertices), skeleton.num_joints))
    return Character("dog", "quadruped", vertices, faces, skeleton, weights)
