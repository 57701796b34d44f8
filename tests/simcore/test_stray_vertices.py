"""Vertices no triangle uses (left behind by modelling tools) must not change units, skeleton, weights or the
simulation: every stage works on the referenced vertices, and the stray ones keep their slot in the output."""

from __future__ import annotations

import numpy as np
import trimesh

from simcore.geometry.capsule_creatures import quadruped
from simcore.ingest import ingest
from simcore.mpm.sampling import sample_volume
from simcore.skeleton.predict import predict_skeleton
from simcore.skinning.predict import compute_weights
from tests.meshes import glb_bytes, joined

FAR = np.array([[1000.0, 1000.0, 1000.0]])


def test_ingest_sizes_and_guesses_units_from_the_referenced_vertices() -> None:
    box = trimesh.creation.box([1.0, 2.0, 1.0])
    stray = trimesh.Trimesh(np.vstack([box.vertices, FAR]), box.faces, process=False)
    mesh = ingest(glb_bytes(stray), "glb")
    assert len(mesh.vertices) == 9  # the stray vertex keeps its slot: exports match the upload's vertex order
    assert mesh.stats["units_applied"] == "m" and mesh.stats["warnings"] == []  # it read as cm before
    assert mesh.stats["unreferenced_vertices"] == 1
    np.testing.assert_allclose(mesh.stats["size"], [1.0, 2.0, 1.0])


def test_skeleton_and_weights_ignore_a_stray_vertex() -> None:
    vertices, faces, skeleton = quadruped()
    with_stray = np.vstack([vertices, FAR])
    clean = predict_skeleton(vertices, faces, method="geometric").skeleton
    stray = predict_skeleton(with_stray, faces, method="geometric").skeleton
    np.testing.assert_allclose(stray.positions, clean.positions)

    plain = compute_weights(vertices, faces, skeleton, method="geodesic").weights.toarray()
    weights = compute_weights(with_stray, faces, skeleton, method="geodesic").weights.toarray()
    np.testing.assert_allclose(weights[:-1], plain, atol=1e-6)
    nearest = int(np.argmin(np.linalg.norm(vertices - FAR, axis=1)))
    np.testing.assert_allclose(weights[-1], plain[nearest], atol=1e-6)  # follows the surface next to it


def test_simulation_volume_ignores_a_stray_vertex() -> None:
    vertices, faces, _ = quadruped()
    clean = sample_volume(vertices, faces, 0.03, seed=2)
    stray = sample_volume(np.vstack([vertices, FAR]), faces, 0.03, seed=2)
    np.testing.assert_array_equal(stray.positions, clean.positions)
    np.testing.assert_array_equal(stray.vertex_particles[:-1], clean.vertex_particles)
    assert stray.vertex_particles[-1] == -1  # no particle out at the stray vertex: it follows its neighbours


def test_a_small_part_far_away_does_not_set_the_units() -> None:
    # A 1.7 m figure with a small prop left 30 m away reads as metres; the whole box (30 m) read as centimetres.
    figure = trimesh.creation.capsule(height=1.2, radius=0.25)
    prop = trimesh.creation.box([0.05, 0.05, 1.0])
    prop.apply_translation([30.0, 0.0, 0.0])
    mesh = ingest(glb_bytes(joined([figure, prop])), "glb")
    assert mesh.stats["units_applied"] == "m" and mesh.stats["warnings"] == []
    # The same in centimetres (prop 3000 cm away) is still centimetres, not millimetres.
    figure.apply_scale(100.0)
    prop.apply_scale(100.0)
    mesh = ingest(glb_bytes(joined([figure, prop])), "glb")
    assert mesh.stats["units_applied"] == "cm"
