"""Tiny generated rigs for the MPM tests: a capsule along +Y with a two-bone chain."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import trimesh
from scipy.spatial.transform import Rotation

from simcore.motion.types import JointAnimation
from simcore.skeleton.types import Skeleton


def capsule_rig(bend_degrees: float = 0.0, frames: int = 4, fps: float = 25.0, root_speed: float = 0.0):
    """(vertices (V, 3), faces (F, 3), skeleton, weights csr (V, 3), animation): a 1 m capsule bending at its middle
    joint by `bend_degrees` over the clip while its root translates along +X at `root_speed` m/s."""
    mesh = trimesh.creation.capsule(height=0.8, radius=0.12, count=[10, 10])
    vertices = np.asarray(mesh.vertices)[:, [0, 2, 1]]  # trimesh capsules are Z-up
    faces = np.asarray(mesh.faces)[:, [0, 2, 1]]  # keep outward winding after the axis swap
    skeleton = Skeleton(np.array([[0, -0.45, 0], [0, 0.0, 0], [0, 0.45, 0]]), np.array([-1, 0, 1]), ["root", "mid", "tip"])
    upper = np.clip((vertices[:, 1] + 0.1) / 0.2, 0.0, 1.0)
    weights = sp.csr_matrix(np.stack([1 - upper, upper, np.zeros_like(upper)], axis=1))
    t = np.linspace(0.0, 1.0, frames)[:, None]
    rotations = np.zeros((frames, 3, 4))
    rotations[..., 3] = 1.0
    rotations[:, 1] = Rotation.from_euler("z", bend_degrees * t, degrees=True).as_quat()
    translations = np.tile(np.array([[0, -0.45, 0], [0, 0.45, 0], [0, 0.45, 0]], dtype=float), (frames, 1, 1))
    translations[:, 0, 0] += root_speed * np.arange(frames) / fps
    return vertices, faces, skeleton, weights, JointAnimation(["root", "mid", "tip"], fps, rotations, translations)


@pytest.fixture
def capsule():
    return capsule_rig
