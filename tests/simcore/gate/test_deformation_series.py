"""The gate's per-frame volume: open pieces that move rigidly apart keep it; a piece that shrinks does not."""

import numpy as np
import trimesh
from scipy.spatial.transform import Rotation

from simcore.gate.measures import deformation_series


def _two_open_cups() -> tuple[np.ndarray, np.ndarray, int]:
    """Two unit spheres with their top caps removed, side by side: a mesh of two open pieces (as armour plates
    and joint covers are), and the first piece's vertex count."""
    sphere = trimesh.creation.icosphere(subdivisions=2)
    v, f = np.asarray(sphere.vertices), np.asarray(sphere.faces[sphere.triangles_center[:, 2] < 0.5])
    return np.concatenate([v, v + [3.0, 0.0, 0.0]]), np.concatenate([f, f + len(v)]), len(v)


def test_open_pieces_moving_rigidly_apart_keep_the_volume():
    v, f, n = _two_open_cups()
    moved = v.copy()
    moved[n:] = (v[n:] - [3.0, 0.0, 0.0]) @ Rotation.from_rotvec([1.2, 0.4, -0.3]).as_matrix().T + [5.0, 2.0, 1.0]
    series = deformation_series(v, f, [np.stack([v, moved])])
    assert series.volume_ratio is not None
    np.testing.assert_allclose(series.volume_ratio, [1.0, 1.0], atol=1e-9)
    np.testing.assert_allclose(series.stretch_high, [1.0, 1.0], atol=1e-9)
    # measured about the whole mesh's centroid, as the gate did before, the same rigid move reads as a change
    centred = [x - x.mean(axis=0) for x in (v, moved)]
    whole = [trimesh.Trimesh(x, f, process=False).volume for x in centred]
    assert abs(whole[1] / whole[0] - 1.0) > 0.05


def test_a_shrinking_piece_lowers_the_volume():
    v, f, n = _two_open_cups()
    shrunk = v.copy()
    shrunk[:n] *= 0.8
    series = deformation_series(v, f, [shrunk[None]])
    assert series.volume_ratio is not None
    assert series.volume_ratio[0] < 0.8
