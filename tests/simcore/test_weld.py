"""Welding coincident vertices: one key per cell (packed into an int64) or per row give the same mesh."""

from __future__ import annotations

import numpy as np
import trimesh

from simcore.geometry import weld
from simcore.geometry.weld import weld_vertices


def _seamed() -> tuple[np.ndarray, np.ndarray]:
    """An icosphere with every face given its own three corners (a flat-shaded export)."""
    sphere = trimesh.creation.icosphere(subdivisions=2)
    return sphere.vertices[sphere.faces].reshape(-1, 3), np.arange(3 * len(sphere.faces)).reshape(-1, 3)


def test_flat_shaded_corners_weld_back_to_the_shared_vertices() -> None:
    v, f = _seamed()
    welded = weld_vertices(v, f)
    assert len(welded.vertices) == len(trimesh.creation.icosphere(subdivisions=2).vertices)
    np.testing.assert_allclose(welded.vertices[welded.index], v)
    assert len(welded.faces) == len(f)


def test_packed_and_row_keys_weld_alike(monkeypatch) -> None:
    """A tolerance whose cell indices overflow the packed key falls back to rows; both paths give one answer."""
    v, f = _seamed()
    packed = weld_vertices(v, f)
    monkeypatch.setattr(weld, "KEY_BITS", 1)  # every key too large to pack: the row path
    rows = weld_vertices(v, f)
    for a, b in ((packed.vertices, rows.vertices), (packed.faces, rows.faces), (packed.index, rows.index)):
        np.testing.assert_array_equal(a, b)
