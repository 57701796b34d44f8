"""Work bombs: small, valid files whose cost lies past the upload check, in the stages after ingest."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import trimesh

from tests.hostile.case import OK, Case, case
from tests.meshes import glb_bytes


def huge_triangles_glb(copies: int) -> bytes:
    """A GLB of `copies` stacked copies of each of two triangles spanning the whole model, one tilted (a few KB
    per thousand copies): every copy needs the voxeliser's densest lattice."""
    corners = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 0], [2, 0, 2], [0, 2, 2]], float)
    vertices = np.tile(corners, (copies, 1))
    faces = np.arange(len(vertices)).reshape(-1, 3)
    return glb_bytes(trimesh.Trimesh(vertices, faces, process=False))


def bomb_cases() -> Iterator[Case]:
    """Files ingest accepts (OK) and a whole job refuses in the stage they would overload (too_large)."""
    for copies in (2, 2_000):
        yield case(f"glb-huge-triangles-{copies}", "mesh", huge_triangles_glb(copies), OK, "too_large")
