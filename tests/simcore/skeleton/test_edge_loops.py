"""Low-poly tubes: a joint at each edge loop (ring of vertices) but the far one."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from simcore.geometry.capsule_creatures import capsule_between
from simcore.skeleton.edge_loops import edge_loops
from simcore.skeleton.geometric import geometric_skeleton


def low_poly_tube(levels: np.ndarray, radius: float, axis: int, sides: int = 6) -> tuple[np.ndarray, np.ndarray]:
    """A closed prism of `sides`-gons at heights `levels` (K,) along `axis`: vertices (K × sides, 3), faces."""
    angle = 2 * np.pi * np.arange(sides) / sides
    across = [k for k in range(3) if k != axis]
    vertices = np.zeros((len(levels) * sides, 3))
    vertices[:, axis] = np.repeat(levels, sides)
    vertices[:, across[0]] = np.tile(radius * np.cos(angle), len(levels))
    vertices[:, across[1]] = np.tile(radius * np.sin(angle), len(levels))
    faces = []
    for ring in range(len(levels) - 1):
        for s in range(sides):
            a, b = ring * sides + s, ring * sides + (s + 1) % sides
            faces += [[a, b, b + sides], [a, b + sides, a + sides]]
    top = (len(levels) - 1) * sides
    faces += [[0, s + 1, s] for s in range(1, sides - 1)] + [[top, top + s, top + s + 1] for s in range(1, sides - 1)]
    return vertices, np.asarray(faces, dtype=np.int64)


LEVELS = np.array([0.0, 0.4, 0.8, 1.2, 1.6, 2.0])


def test_edge_loops_are_the_ring_centres_in_order():
    vertices, _ = low_poly_tube(LEVELS, 0.15, axis=1)
    rings = edge_loops(vertices, 0.5)
    assert rings is not None
    np.testing.assert_allclose(np.sort(rings[:, 1]), LEVELS, atol=1e-9)
    assert np.all(np.diff(rings[:, 1]) > 0) or np.all(np.diff(rings[:, 1]) < 0)
    np.testing.assert_allclose(rings[:, [0, 2]], 0.0, atol=1e-9)


@pytest.mark.parametrize(("vertices", "why"), [
    (low_poly_tube(np.linspace(0.0, 2.0, 21), 0.15, axis=1)[0], "rings 0.1 apart, 0.3 thick: fine tessellation"),
    (low_poly_tube(np.array([0.0, 2.0]), 0.15, axis=1)[0], "two rings: a rigid stick, nothing to bend"),
    (np.vstack([low_poly_tube(LEVELS, 0.15, axis=1)[0], [[0.1, 0.2, 0.0]]]), "a stray vertex between rings"),
    (low_poly_tube(np.array([0.0, 0.5, 1.0]), 0.45, axis=1)[0], "three rings on a block not twice as long as thick"),
    (low_poly_tube(np.concatenate([np.linspace(0.0, 0.2, 300), np.linspace(0.9, 1.1, 300),
                                   np.linspace(1.8, 2.0, 300)]), 0.15, axis=1)[0],
     "three dense bands of rings, chained into three wide groups"),
    (capsule_between(np.zeros(3), np.array([0.0, 2.0, 0.0]), 0.15).vertices, "a smooth capsule"),
])
def test_no_edge_loops_where_the_mesh_is_not_a_low_poly_tube(vertices: np.ndarray, why: str):
    assert edge_loops(vertices, 0.5) is None, why


@pytest.mark.parametrize(("axis", "label"), [(1, "upright: lower end"), (2, "level: back (-Z) end")])
def test_a_low_poly_tube_gets_a_joint_at_each_ring_but_the_far_one(axis: int, label: str):
    vertices, faces = low_poly_tube(LEVELS[::-1] + 0.3, 0.15, axis=axis)  # rings listed from the far end
    skeleton, report = geometric_skeleton(vertices, faces)
    assert report["edge_loops"] == len(LEVELS), label
    expected = np.zeros((len(LEVELS) - 1, 3))
    expected[:, axis] = LEVELS[:-1] + 0.3  # rooted at the ring with the smaller coordinate
    np.testing.assert_allclose(skeleton.positions, expected, atol=1e-9, err_msg=label)
    assert skeleton.parents.tolist() == list(range(-1, len(LEVELS) - 2)), label



def test_a_tube_with_an_arm_on_its_rings_is_not_rigged_by_them():
    # An arm whose box corners lie on two of the post's rings: every vertex is on a ring, but the body branches
    # (its medial graph has a junction), so it keeps the medial skeleton with a joint in the arm.
    post, post_faces = low_poly_tube(LEVELS, 0.15, axis=1)
    arm = trimesh.creation.box(bounds=[[0.0, 0.8, -0.1], [0.6, 1.2, 0.1]])
    vertices, faces = np.vstack([post, arm.vertices]), np.vstack([post_faces, arm.faces + len(post)])
    assert edge_loops(vertices, 0.5) is not None  # the rings alone would make it a tube
    skeleton, report = geometric_skeleton(vertices, faces)
    assert "edge_loops" not in report
    assert skeleton.positions[:, 0].max() > 0.3  # a joint out in the arm
