"""Parts no bone comes near (a second character, a far prop) are found, so the stage can warn about them."""

from __future__ import annotations

import numpy as np
import trimesh

from simcore.geometry.capsule_creatures import capsule_between, stick_humanoid
from simcore.geometry.parts import surface_parts
from simcore.skeleton.coverage import unreached_parts
from simcore.skeleton.predict import predict_skeleton


def _with(extra: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray, int]:
    vertices, faces, _ = stick_humanoid()
    both = trimesh.util.concatenate([trimesh.Trimesh(vertices, faces, process=False), extra])
    return np.asarray(both.vertices), np.asarray(both.faces), len(faces)


def test_a_second_figure_beside_the_first_is_unreached() -> None:
    v, f, _ = stick_humanoid()
    second = trimesh.Trimesh(v + [2.5, 0.0, 0.0], f, process=False)
    vertices, faces, first_faces = _with(second)
    skeleton = predict_skeleton(vertices, faces).skeleton
    far = unreached_parts(surface_parts(vertices, faces), skeleton)
    rigged_second = skeleton.positions[:, 0].mean() > 1.25  # the fit takes one of the two
    assert far and all((p.faces.min() >= first_faces) != rigged_second for p in far)  # the other figure's parts


def test_a_held_prop_is_reached() -> None:
    vertices, faces, _ = _with(capsule_between(np.array([-0.72, 1.32, 0.05]), np.array([-0.72, 2.32, 0.05]), 0.02))
    skeleton = predict_skeleton(vertices, faces).skeleton
    assert unreached_parts(surface_parts(vertices, faces), skeleton) == []
