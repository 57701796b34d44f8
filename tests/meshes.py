"""Test meshes built with trimesh, typed as what they are (trimesh types these results as any Geometry or format)."""

from __future__ import annotations

from collections.abc import Sequence

import trimesh


def joined(meshes: Sequence[trimesh.Trimesh]) -> trimesh.Trimesh:
    """The meshes as one triangle soup (trimesh.util.concatenate), vertices and faces in the given order."""
    mesh = trimesh.util.concatenate(list(meshes))
    assert isinstance(mesh, trimesh.Trimesh)
    return mesh


def glb_bytes(geometry: trimesh.Trimesh | trimesh.Scene) -> bytes:
    """The mesh or scene written as a GLB file."""
    data = geometry.export(file_type="glb")
    assert isinstance(data, bytes)
    return data
