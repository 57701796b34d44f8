"""A prop held up (a sword, a staff) must not stop the humanoid fit: it is tried away, and still skinned."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from simcore.geometry.capsule_creatures import capsule_between, stick_humanoid
from simcore.geometry.parts import surface_parts
from simcore.skeleton.candidates import humanoid_candidate
from simcore.skeleton.props import parts_to_try_without
from simcore.skinning.predict import compute_weights
from tests.meshes import joined


@pytest.fixture(scope="module")
def swordsman() -> tuple[np.ndarray, np.ndarray, int]:
    """The stick humanoid with a 1 m sword held upright in its right hand (a separate part); (V, F, sword's first vertex)."""
    vertices, faces, joints = stick_humanoid()
    hand = np.asarray(joints["RightHand"])
    sword = capsule_between(hand + [0.0, -0.1, 0.05], hand + [0.0, 0.9, 0.05], 0.02)
    body = trimesh.Trimesh(vertices, faces, process=False)
    both = joined([body, sword])
    return np.asarray(both.vertices), np.asarray(both.faces), len(body.vertices)


def test_the_sword_is_the_part_that_sticks_out(swordsman) -> None:
    vertices, faces, first = swordsman
    sword = np.arange(len(faces)) >= np.flatnonzero((faces >= first).all(axis=1))[0]
    masks = parts_to_try_without(surface_parts(vertices, faces), len(faces))  # the capsule soup's own parts come with it
    assert any(np.array_equal(mask, sword) for mask in masks)


def test_a_humanoid_holding_a_sword_up_is_fitted_without_it(swordsman) -> None:
    vertices, faces, first = swordsman
    candidate, report = humanoid_candidate(vertices, faces, surface_parts(vertices, faces), max_joints=64, up_axis=None,
                                           forward_axis=None, force=False)  # auto's humanoid candidate
    assert candidate is not None, report  # the sword's tip read as the head before
    assert report["prop_triangles_left_out"] > 0
    skeleton = candidate.skeleton
    assert skeleton.positions[:, 1].max() < 1.8  # no joint up the sword (its tip is at 2.3 m)
    weights = compute_weights(vertices, faces, skeleton, method="geodesic").weights.toarray()
    right_arm = [k for k, n in enumerate(skeleton.names) if n.startswith("mixamorig:Right") and ("Hand" in n or "Fore" in n)]
    assert weights[first:, right_arm].sum(axis=1).mean() > 0.9  # the sword follows the hand holding it


def test_a_humanoid_in_a_skirt_is_fitted_without_it() -> None:
    vertices, faces, _ = stick_humanoid()
    skirt = trimesh.creation.cone(radius=0.35, height=0.9, sections=32)
    skirt.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0]))  # apex up (+Y)
    skirt.apply_translation([0.0, 0.12, 0.0])
    side = ~(np.abs(skirt.vertices[skirt.faces][:, :, 1] - 0.12) < 1e-6).all(axis=1)  # open at the hem
    both = joined([trimesh.Trimesh(vertices, faces, process=False),
                                     trimesh.Trimesh(skirt.vertices, skirt.faces[side], process=False)])
    vertices, faces = np.asarray(both.vertices), np.asarray(both.faces)
    candidate, report = humanoid_candidate(vertices, faces, surface_parts(vertices, faces), max_joints=64, up_axis=None,
                                           forward_axis=None, force=False)
    assert candidate is not None, report  # the skirt's shell hid the biped before
    assert report["prop_triangles_left_out"] == int(side.sum())


def test_a_part_inside_the_silhouette_is_not_tried_away() -> None:
    vertices, faces, _ = stick_humanoid()
    belt = capsule_between(np.array([-0.15, 0.95, 0.0]), np.array([0.15, 0.95, 0.0]), 0.03)  # within the body's box
    both = joined([trimesh.Trimesh(vertices, faces, process=False), belt])
    belt_faces = np.arange(len(faces), len(both.faces))
    assert not any(mask[belt_faces].any() for mask in parts_to_try_without(surface_parts(both.vertices, both.faces), len(both.faces)))
    one_piece = capsule_between(np.array([0.0, 0.2, 0.0]), np.array([0.0, 1.5, 0.0]), 0.2)
    assert parts_to_try_without(surface_parts(one_piece.vertices, one_piece.faces), len(one_piece.faces)) == []
