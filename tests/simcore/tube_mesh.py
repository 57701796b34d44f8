"""A tube mesh along +y with a three-joint chain on its axis, for skinning and motion tests."""

from __future__ import annotations

import numpy as np

from simcore.skeleton.types import Skeleton

RADIUS = 0.2


def tube(rings: int = 41, sides: int = 12) -> tuple[np.ndarray, np.ndarray, Skeleton]:
    """A tube along +y from 0 to 2, `rings` rings apart evenly, bones 0 → 1 → 2 along its axis."""
    angle = np.linspace(0.0, 2 * np.pi, sides, endpoint=False)
    y = np.linspace(0.0, 2.0, rings)
    vertices = np.array([(RADIUS * np.cos(t), h, RADIUS * np.sin(t)) for h in y for t in angle])
    faces = []
    for i in range(rings - 1):
        for k in range(sides):
            p, q = i * sides + k, i * sides + (k + 1) % sides
            faces += [[p, q, p + sides], [q, q + sides, p + sides]]
    skeleton = Skeleton(np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 2.0, 0.0]]), np.array([-1, 0, 1]), ["a", "b", "c"])
    return vertices, np.array(faces), skeleton
