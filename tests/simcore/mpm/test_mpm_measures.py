"""Volume measures for the refine report: per-part volumes that open and multi-part meshes keep under rigid motion."""

import numpy as np
import trimesh
from scipy.spatial.transform import Rotation

from simcore.mpm.measures import part_volumes, volume_change, volume_parts


def _open_cup() -> tuple[np.ndarray, np.ndarray]:
    """A unit sphere with its top cap removed: an open surface."""
    sphere = trimesh.creation.icosphere(subdivisions=2)
    keep = sphere.triangles_center[:, 2] < 0.5
    return np.asarray(sphere.vertices), np.asarray(sphere.faces[keep])


def test_closed_part_volume_is_the_enclosed_volume():
    box = trimesh.creation.box(extents=[1.0, 2.0, 3.0])
    v, f = np.asarray(box.vertices) + 5.0, np.asarray(box.faces)
    parts = volume_parts(v, f)
    assert parts.max() == 0
    np.testing.assert_allclose(part_volumes(v, f, parts)[0], [6.0], rtol=1e-9)


def test_open_part_keeps_its_volume_under_rigid_motion():
    v, f = _open_cup()
    moved = v @ Rotation.from_rotvec([0.3, -0.5, 0.2]).as_matrix().T + [2.0, 1.0, -3.0]
    parts = volume_parts(v, f)
    rest, after = part_volumes(np.stack([v, moved]), f, parts)
    np.testing.assert_allclose(after, rest, rtol=1e-9)
    assert volume_change(np.stack([rest, after]), rest).max() < 1e-9
    # the origin-referenced sum is not a measure for an open surface: it changes under the same motion
    before_o, after_o = (trimesh.Trimesh(x, f, process=False).volume for x in (v, moved))
    assert abs(after_o / before_o - 1.0) > 0.05


def test_opposite_changes_of_two_parts_do_not_cancel_and_seams_do_not_split():
    box = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    a_v, a_f = np.asarray(box.vertices), np.asarray(box.faces)
    # the second box with every face's corners duplicated (an unwelded mesh, as UV seams leave it)
    b_v, b_f = (a_v + [3.0, 0.0, 0.0])[a_f.reshape(-1)], np.arange(3 * len(a_f)).reshape(-1, 3) + len(a_v)
    v, f = np.concatenate([a_v, b_v]), np.concatenate([a_f, b_f])
    parts = volume_parts(v, f)
    assert parts.max() == 1
    shrink, grow = 0.9 ** (1 / 3), 1.1 ** (1 / 3)
    deformed = v.copy()
    deformed[: len(a_v)] *= shrink
    deformed[len(a_v):] = (v[len(a_v):] - [3.0, 0.0, 0.0]) * grow + [3.0, 0.0, 0.0]
    vols = part_volumes(np.stack([v, deformed]), f, parts)
    np.testing.assert_allclose(vols[1] / vols[0], [0.9, 1.1], rtol=1e-9)
    np.testing.assert_allclose(volume_change(vols, vols[0])[1], 0.1, rtol=1e-9)
    assert abs(vols[1].sum() / vols[0].sum() - 1.0) < 1e-9  # the total alone would hide both changes
