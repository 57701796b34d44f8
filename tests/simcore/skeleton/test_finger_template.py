"""Finger template fallback: section loops tell five- and four-fingered hands from mittens; the joints land on the
right fingers."""

from __future__ import annotations

import numpy as np
import trimesh

from simcore.skeleton.finger_template import finger_names, section_loops, template_fingers
from simcore.skeleton.mixamo import FINGERS, FOUR_FINGERS
from tests.meshes import joined

WRIST, ELBOW, FORWARD = np.array([0.0, 0.0, 0.0]), np.array([-1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])


def box(lo, hi) -> trimesh.Trimesh:
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return trimesh.creation.box(extents=hi - lo, transform=trimesh.transformations.translation_matrix((lo + hi) / 2))


def left_hand(fingers: bool, count: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """A palm (x up to 0.4) and `count` finger boxes 4 mm apart across z -0.2..0.2 (x 0.4..0.8, index at +z;
    fused at voxel size), or a mitten."""
    parts = [box([-0.2, -0.05, -0.2], [0.4, 0.05, 0.2])]
    if fingers:
        width = 0.4 / count
        parts += [box([0.4, -0.04, z], [0.8, 0.04, z + width - 0.004]) for z in -0.2 + width * np.arange(count)]
    else:
        parts.append(box([0.4, -0.04, -0.2], [0.8, 0.04, 0.2]))
    mesh = joined(parts).subdivide().subdivide()  # real hands have many vertices
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


def test_section_loops_counts_separate_shells():
    v, f = left_hand(fingers=True)
    loops = section_loops(v, f, np.array([0.6, 0, 0]), np.array([1.0, 0, 0]))
    assert len(loops) == 4
    assert np.allclose(sorted(c[2] for c in loops), [-0.152, -0.052, 0.048, 0.148], atol=0.01)  # each finger's centre
    v, f = left_hand(fingers=False)
    assert len(section_loops(v, f, np.array([0.6, 0, 0]), np.array([1.0, 0, 0]))) == 1


def test_the_loop_count_two_planes_reach_names_the_fingers():
    assert finger_names([4, 4, 4, 3, 3]) == FINGERS
    assert finger_names([3, 3, 2, 2, 1]) == FOUR_FINGERS  # the shorter fingers end before the farther planes
    assert finger_names([3, 1, 1, 1, 1]) is None  # one plane alone is not evidence
    assert finger_names([1, 1, 1, 1, 1]) is None
    assert finger_names([4, 4, 4, 3, 3], (FOUR_FINGERS,)) == FOUR_FINGERS  # read again as four-fingered


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


def test_a_four_fingered_hand_gets_its_three_fingers_where_the_sections_show_them():
    v, f = left_hand(fingers=True, count=3)
    joints, info = template_fingers(v, f, WRIST, ELBOW, FORWARD, "Left")
    assert joints is not None and info["fingers"] == 4
    assert sorted(joints) == sorted(f"{n}{k}" for n in FOUR_FINGERS for k in (1, 2, 3))  # no Ring slots
    for finger, z in (("Index", 0.133), ("Middle", 0.0), ("Pinky", -0.133)):  # the three boxes' centres
        assert all(abs(joints[f"{finger}{k}"][2] - z) < 0.02 for k in (1, 2, 3))
    assert 0.3 < joints["Middle1"][0] < joints["Middle3"][0] < 0.8


def test_a_five_fingered_hand_cannot_be_read_as_four_fingered():
    v, f = left_hand(fingers=True)
    joints, info = template_fingers(v, f, WRIST, ELBOW, FORWARD, "Left", (FOUR_FINGERS,))
    assert joints is None and "three fingers" in info["reason"]


def test_hands_that_disagree_are_both_read_as_four_fingered():
    """Left: three touching fingers. Right (mirrored at x < 0): four, one of them short, as a held prop or a fold
    would add one; read again as four-fingered, both hands get 12 joints."""
    from simcore.skeleton.hands import fit_fingers

    left_v, left_f = left_hand(fingers=True, count=3)
    parts = [box([0.4, -0.04, z], [0.8 if z != -0.2 else 0.62, 0.04, z + 0.096]) for z in (-0.2, -0.1, 0.0, 0.1)]
    right = joined([box([-0.2, -0.05, -0.2], [0.4, 0.05, 0.2]), *parts]).subdivide().subdivide()
    right_v = np.asarray(right.vertices) * np.array([-1.0, 1.0, 1.0]) - np.array([2.0, 0.0, 0.0])
    right_f = np.asarray(right.faces)[:, ::-1]
    vertices = np.vstack([left_v, right_v])
    faces = np.vstack([left_f, right_f + len(left_v)])
    body = {"LeftHand": WRIST, "LeftForeArm": ELBOW, "RightHand": np.array([-2.0, 0.0, 0.0]),
            "RightForeArm": np.array([-1.0, 0.0, 0.0]), "Hips": np.array([-1.0, -1.0, 0.0])}
    joints, report = fit_fingers(vertices, faces, body, np.array([0.0, 1.0, 0.0]), FORWARD, np.array([1.0, 0, 0]))
    assert joints is not None, report
    assert len(joints) == 24 and "LeftHandRing1" not in joints and "RightHandRing1" not in joints
    assert "read_again" in report["right"]


def _two_hands(right_fingers: bool, prop: bool) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """A three-fingered left hand and, mirrored across x = -1, a right hand with those fingers or a mitten, holding
    a separate prop (a plate over the palm, more than half a forearm away from the other hand's mirror image) when
    `prop`; with the body joints."""
    left_v, left_f = left_hand(fingers=True, count=3)
    right = left_hand(fingers=right_fingers, count=3)
    right_v, right_f = right[0] * np.array([-1.0, 1.0, 1.0]) - np.array([2.0, 0.0, 0.0]), right[1][:, ::-1]
    meshes = [(left_v, left_f), (right_v, right_f)]
    if prop:
        bar = box([-2.5, 0.6, -0.2], [-2.2, 0.7, 0.2]).subdivide().subdivide()
        meshes.append((np.asarray(bar.vertices), np.asarray(bar.faces)))
    offsets = np.cumsum([0] + [len(v) for v, _ in meshes[:-1]])
    vertices = np.vstack([v for v, _ in meshes])
    faces = np.vstack([f + o for (_, f), o in zip(meshes, offsets)])
    body = {"LeftHand": WRIST, "LeftForeArm": ELBOW, "RightHand": np.array([-2.0, 0.0, 0.0]),
            "RightForeArm": np.array([-1.0, 0.0, 0.0]), "Hips": np.array([-1.0, -1.0, 0.0])}
    return vertices, faces, body


def _fingers(right_fingers: bool, prop: bool):
    from simcore.skeleton.hands import fit_fingers

    vertices, faces, body = _two_hands(right_fingers, prop)
    return fit_fingers(vertices, faces, body, np.array([0.0, 1.0, 0.0]), FORWARD, np.array([1.0, 0, 0]))


def test_a_prop_held_in_one_hand_is_left_out_of_its_reading():
    joints, report = _fingers(right_fingers=True, prop=True)
    assert joints is not None, report
    assert report["right"]["prop_triangles"] > 0 and "prop_triangles" not in report["left"]
    assert "mirrored_from" not in report["right"]  # read off its own surface
    for name in (n for n in joints if n.startswith("LeftHand")):  # the two hands' joints are mirror images
        mirrored = joints[name] * np.array([-1.0, 1.0, 1.0]) - np.array([2.0, 0.0, 0.0])
        assert np.linalg.norm(joints[name.replace("Left", "Right")] - mirrored) < 0.05


def test_a_hand_whose_grip_hides_its_fingers_mirrors_the_other_hand():
    joints, report = _fingers(right_fingers=False, prop=True)
    assert joints is not None, report
    assert report["right"]["mirrored_from"] == "left"
    assert len(joints) == 24
    mirrored = joints["LeftHandMiddle2"] * np.array([-1.0, 1.0, 1.0]) - np.array([2.0, 0.0, 0.0])
    assert np.allclose(joints["RightHandMiddle2"], mirrored)


def test_a_mitten_without_a_prop_is_not_given_the_other_hands_fingers():
    joints, report = _fingers(right_fingers=False, prop=False)
    assert joints is None and report["separable"] is False
    assert "mirrored_from" not in report["right"]
