"""Parts no bone comes near (a second character, a far prop) are found, so the stage can warn about them."""

from __future__ import annotations

import numpy as np
import trimesh

from simcore.geometry.capsule_creatures import capsule_between, stick_humanoid
from simcore.geometry.parts import surface_parts
from simcore.skeleton.coverage import unreached_parts
from simcore.skeleton.predict import predict_skeleton
from simcore.skeleton.types import Skeleton
from tests.meshes import joined


def _with(extra: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray, int]:
    vertices, faces, _ = stick_humanoid()
    both = joined([trimesh.Trimesh(vertices, faces, process=False), extra])
    return np.asarray(both.vertices), np.asarray(both.faces), len(faces)


def test_a_second_figure_beside_the_first_is_unreached() -> None:
    v, f, _ = stick_humanoid()
    second = trimesh.Trimesh(v + [2.5, 0.0, 0.0], f, process=False)
    vertices, faces, first_faces = _with(second)
    skeleton = predict_skeleton(vertices, faces, method="humanoid").skeleton
    far = unreached_parts(vertices, faces, surface_parts(vertices, faces), skeleton)
    rigged_second = skeleton.positions[:, 0].mean() > 1.25  # the fit takes one of the two
    assert far and all((p.faces.min() >= first_faces) != rigged_second for p in far)  # the other figure's parts


def test_a_held_prop_is_reached() -> None:
    vertices, faces, _ = _with(capsule_between(np.array([-0.72, 1.32, 0.05]), np.array([-0.72, 2.32, 0.05]), 0.02))
    skeleton = predict_skeleton(vertices, faces, method="humanoid").skeleton
    assert unreached_parts(vertices, faces, surface_parts(vertices, faces), skeleton) == []


def test_a_blob_around_its_one_joint_and_a_big_flat_part_near_a_bone_are_reached() -> None:
    ball = trimesh.creation.icosphere(subdivisions=2, radius=1.0)  # one joint at its centre, 1.0 from the surface
    ball_skeleton = Skeleton(np.zeros((1, 3)), np.array([-1]), ["root"])
    assert unreached_parts(ball.vertices, ball.faces, surface_parts(ball.vertices, ball.faces), ball_skeleton) == []
    # A 10 m wall whose corners are far from the figure's bones, but whose surface passes by its feet.
    wall = trimesh.Trimesh([[-5, 0, -0.3], [5, 0, -0.3], [5, 10, -0.3], [-5, 10, -0.3]], [[0, 1, 2], [0, 2, 3]], process=False)
    vertices, faces, _ = _with(wall)
    skeleton = predict_skeleton(vertices, faces, method="humanoid").skeleton
    assert unreached_parts(vertices, faces, surface_parts(vertices, faces), skeleton) == []
