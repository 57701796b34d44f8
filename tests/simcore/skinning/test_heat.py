"""Bone heat as Blender heats it: the normal-cone distance, unheated vertices and the weight limit."""

from __future__ import annotations

import numpy as np
import trimesh

from simcore.skeleton.types import Skeleton
from simcore.skinning.heat import LIMIT_END, LIMIT_START, _limited, heat_weights
from tests.meshes import joined


def _legs() -> tuple[np.ndarray, np.ndarray, Skeleton]:
    """Two upright capsules (radius 0.1) 0.3 apart, each with its own two-joint bone, hung from a root above."""
    left = trimesh.creation.capsule(height=1.0, radius=0.1, count=[12, 12])
    right = left.copy()
    left.apply_translation([-0.15, 0.0, 0.0])
    right.apply_translation([0.15, 0.0, 0.0])
    mesh = joined([left, right])
    v = mesh.vertices[:, [0, 2, 1]] * [1, 1, -1]  # capsule axis Z → Y (a proper rotation: faces still face out)
    f = mesh.faces
    joints = np.array([[0.0, 0.8, 0.0], [-0.15, 0.5, 0.0], [-0.15, -0.5, 0.0], [0.15, 0.5, 0.0], [0.15, -0.5, 0.0]])
    return v, f, Skeleton(joints, np.array([-1, 0, 1, 0, 3]), ["root", "l_up", "l_low", "r_up", "r_low"])


def test_each_leg_follows_its_own_bone_whichever_way_its_faces_wind() -> None:
    v, f, skeleton = _legs()
    w = heat_weights(v, f, skeleton)
    np.testing.assert_allclose(w.sum(axis=1), 1.0, atol=1e-9)
    left = v[:, 0] < 0
    assert w[left][:, [3, 4]].max() == 0.0  # no weight crosses the gap to the other leg's bones
    assert w[~left][:, [1, 2]].max() == 0.0
    assert w[v[:, 1] < 0.0, 1:].sum(axis=1).min() > 0.99  # the root's bones end at the legs' tops
    assert trimesh.Trimesh(v, f).volume > 0
    inverted = heat_weights(v, f[:, [0, 2, 1]], skeleton)  # inward normals are turned outwards first
    np.testing.assert_allclose(inverted, w, atol=1e-9)


def test_weight_limit_fades_small_weights_to_nothing() -> None:
    w = np.array([0.0, LIMIT_END * 0.99, LIMIT_END, 0.5 * (LIMIT_END + LIMIT_START), LIMIT_START, 0.5])
    np.testing.assert_allclose(_limited(w), [0.0, 0.0, 0.0, 0.5 * LIMIT_START, LIMIT_START, 0.5])
