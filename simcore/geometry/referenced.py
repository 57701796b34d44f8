"""The vertices a mesh's faces use.

Files can carry vertices no triangle references (left behind by a modelling tool, or shared buffers). They
are invisible but would set the bounding box, so unit guessing, voxel grids, skeletons, weights and the
simulation domain all work on the referenced vertices only; the unreferenced ones keep their place in the
vertex order so exported files match the upload.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simcore.arrays import unique_ints


@dataclass
class ReferencedMesh:
    """ids: (U,) int64 sorted original indices of the referenced vertices; vertices: (U, 3) float64 their
    positions; faces: (F, 3) int64 the triangles re-indexed into `vertices`; count: the original vertex count."""

    ids: np.ndarray
    vertices: np.ndarray
    faces: np.ndarray
    count: int

    @property
    def complete(self) -> bool:
        """True when every vertex is referenced (the compact mesh is the mesh)."""
        return len(self.ids) == self.count


def referenced_mesh(vertices: np.ndarray, faces: np.ndarray) -> ReferencedMesh:
    """The mesh restricted to the vertices its faces use. vertices: (V, 3), faces: (F, 3) ints in [0, V)."""
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    ids = unique_ints(f)
    remap = np.full(len(v), -1, dtype=np.int64)
    remap[ids] = np.arange(len(ids))
    return ReferencedMesh(ids, v[ids], remap[f], len(v))
