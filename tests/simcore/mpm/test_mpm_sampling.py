import numpy as np

from simcore.mpm.sampling import sample_volume


def test_every_vertex_is_a_particle_and_volume_is_filled(capsule):
    vertices, faces, *_ = capsule()
    s = sample_volume(vertices, faces, 0.02, seed=3)
    assert np.all(s.vertex_particles >= 0)
    np.testing.assert_allclose(s.positions[s.vertex_particles], vertices)
    assert s.counts["interior"] > 5 * len(vertices)
    # the capsule's solid volume: cylinder + sphere
    exact = np.pi * 0.12**2 * 0.8 + 4 / 3 * np.pi * 0.12**3
    assert abs(s.volume - exact) / exact < 0.15
    r = np.hypot(s.positions[:, 0], s.positions[:, 2])
    assert np.all(r < 0.12 + 0.005)  # nothing pokes out of the surface by more than a quarter spacing


def test_sampling_is_deterministic_and_respects_the_budget(capsule):
    vertices, faces, *_ = capsule()
    a = sample_volume(vertices, faces, 0.015, seed=1, max_particles=2000)
    b = sample_volume(vertices, faces, 0.015, seed=1, max_particles=2000)
    np.testing.assert_array_equal(a.positions, b.positions)
    assert a.count <= 2000
    assert a.notes and "thinned" in a.notes[0]
    assert np.all(a.vertex_particles >= 0)  # vertices survive thinning while they fit in half the budget
