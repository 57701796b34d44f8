"""Finger template fallback: section loops tell fingers from mittens; the 15 joints land on the right fingers."""

from __future__ import annotations

import numpy as np
import trimesh

from simcore.skeleton.finger_template import section_loops, template_fingers
from tests.meshes import joined

WRIST, ELBOW, FORWARD = np.array([0.0, 0.0, 0.0]), np.array([-1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])


def box(lo, hi) -> trimesh.Trimesh:
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return trimesh.creation.box(extents=hi - lo, transform=trimesh.transformations.translation_matrix((lo + hi) / 2))


def left_hand(fingers: bool) -> tuple[np.ndarray, np.ndarray]:
    """A palm (x up to 0.4) and four finger boxes 4 mm apart (x 0.4..0.8, index at +z; fused at voxel size), or a mitten."""
    parts = [box([-0.2, -0.05, -0.2], [0.4, 0.05, 0.2])]
    if fingers:
        parts += [box([0.4, -0.04, z], [0.8, 0.04, z + 0.096]) for z in (-0.2, -0.1, 0.0, 0.1)]
    else:
        parts.append(box([0.4, -0.04, -0.2], [0.8, 0.04, 0.2]))
    mesh = joined(parts).subdivide().subdivide()  # real hands have many vertices
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


def test_section_loops_counts_separate_shells():
    v, f = left_hand(fingers=True)
    assert section_loops(v, f, np.array([0.6, 0, 0]), np.array([1.0, 0, 0])) == 4
    v, f = left_hand(fingers=False)
    assert section_loops(v, f, np.array([0.6, 0, 0]), np.array([1.0, 0, 0])) == 1


def test_touching_fingers_get_template_joints_with_the_index_in_front():
    v, f = left_hand(fingers=True)
    joints, info = template_fingers(v, f, WRIST, ELBOW, FORWARD, "Left")
    assert joints is not None and info["template"] is True
    assert len(joints) == 15
    assert joints["Index1"][2] > joints["Middle1"][2] > joints["Ring1"][2] > joints["Pinky1"][2]
    assert all(joints[f"Middle{k}"][0] > 0.3 for k in (1, 2, 3))  # past the knuckles, inside the hand's length
    assert joints["Middle3"][0] < 0.8


def test_a_mitten_gets_no_fingers():
    v, f = left_hand(fingers=False)
    joints, info = template_fingers(v, f, WRIST, ELBOW, FORWARD, "Left")
    assert joints is None and "mitten" in info["reason"]
