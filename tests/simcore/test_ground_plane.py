"""A ground plane under a model (the floor a downloaded character stood on) is left out of the skeleton and
bound to the root joint, so the character still gets its own rig."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from simcore.geometry.capsule_creatures import capsule_between, stick_humanoid
from simcore.geometry.ground import ground_faces as ground_of_parts
from simcore.geometry.parts import surface_parts
from simcore.options import JobOptions
from simcore.pipeline import PipelineInputs, run_pipeline
from tests.meshes import glb_bytes, joined


def _plane(y: float, half: float, centre: tuple[float, float] = (0.0, 0.0), tilt_deg: float = 0.0) -> trimesh.Trimesh:
    """A two-triangle square at height y, facing +Y, optionally tilted about X."""
    x, z = centre
    corners = np.array([[x - half, 0, z - half], [x + half, 0, z - half], [x + half, 0, z + half], [x - half, 0, z + half]])
    t = np.deg2rad(tilt_deg)
    corners = corners @ np.array([[1, 0, 0], [0, np.cos(t), np.sin(t)], [0, -np.sin(t), np.cos(t)]]).T + [0, y, 0]
    return trimesh.Trimesh(corners, [[0, 2, 1], [0, 3, 2]], process=False)


def ground_faces(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    return ground_of_parts(surface_parts(vertices, faces), len(faces))


def _join(*meshes: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    mesh = joined(list(meshes))
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


@pytest.fixture(scope="module")
def figure() -> trimesh.Trimesh:
    vertices, faces, _ = stick_humanoid()
    return trimesh.Trimesh(vertices, faces, process=False)


def test_a_floor_under_the_feet_is_ground(figure: trimesh.Trimesh) -> None:
    v, f = _join(figure, _plane(0.0, 2.0))
    ground = ground_faces(v, f)
    assert ground.sum() == 2 and ground[-2:].all()


def test_a_base_disc_is_ground(figure: trimesh.Trimesh) -> None:
    disc = trimesh.creation.cylinder(radius=0.6, height=0.05, sections=32)  # along Z: turn it level
    disc.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    disc.apply_translation([0.0, -0.02, 0.0])  # the feet rest 0.5 cm inside its top
    v, f = _join(figure, disc)
    ground = ground_faces(v, f)
    assert ground[len(figure.faces):].all() and not ground[:len(figure.faces)].any()


@pytest.mark.parametrize(("plane", "why"), [
    (lambda: _plane(2.0, 2.0), "above the head"),
    (lambda: _plane(0.0, 0.15, centre=(1.0, 0.0)), "beside the model, not under its centre"),
    (lambda: _plane(0.0, 2.0, tilt_deg=30.0), "a ramp, not level"),
])
def test_other_flat_parts_are_not_ground(figure: trimesh.Trimesh, plane, why: str) -> None:
    v, f = _join(figure, plane())
    assert not ground_faces(v, f).any(), why


def test_a_lone_plane_or_a_plain_model_has_no_ground(figure: trimesh.Trimesh) -> None:
    v, f = _join(_plane(0.0, 1.0), _plane(0.5, 1.0))
    assert not ground_faces(v, f).any()
    assert not ground_faces(figure.vertices, figure.faces).any()
    tube = capsule_between(np.array([0.0, 0.2, 0.0]), np.array([0.0, 1.5, 0.0]), 0.2)
    assert not ground_faces(tube.vertices, tube.faces).any()


def test_a_character_on_a_floor_is_still_rigged_as_a_humanoid(figure: trimesh.Trimesh, tmp_path: Path) -> None:
    floor = _plane(0.0, 2.0)
    upload = tmp_path / "on_floor.glb"
    upload.write_bytes(glb_bytes(joined([figure, floor])))
    state = run_pipeline(PipelineInputs(upload, "glb"), JobOptions(), tmp_path / "out")  # both exports validate
    assert state.skeleton is not None and state.weights is not None and state.mesh is not None
    assert state.report["skeleton"]["method"] == "humanoid"  # the floor made it a 2-body geometric skeleton before
    assert state.report["skeleton"]["ground_triangles"] == 2
    assert any("ground plane" in w["message"] for w in state.report["warnings"])
    floor_rows = np.flatnonzero(np.isin(np.round(state.mesh.vertices, 6), np.round(floor.vertices, 6)).all(axis=1))
    assert len(floor_rows) == 4
    weights = state.weights.toarray()
    np.testing.assert_allclose(weights[floor_rows, 0], 1.0)  # the root joint alone: no corner follows a foot
    assert state.skeleton.parents[0] == -1
