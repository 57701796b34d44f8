import numpy as np

from simcore.mpm.sampling import MIN_PARTICLES_PER_CELL, sample_on_grid, sample_volume


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


def test_a_budget_too_small_for_the_grid_coarsens_it(capsule):
    vertices, faces, *_ = capsule()
    extent = float(np.ptp(vertices, axis=0).max())
    roomy = sample_on_grid(vertices, faces, extent, 32, 14, max_particles=None, seed=2)
    assert roomy.grid == 32 and roomy.note is None and roomy.per_cell >= MIN_PARTICLES_PER_CELL
    tight = sample_on_grid(vertices, faces, extent, 96, 14, max_particles=1000, seed=2)
    assert tight.grid < 96 and tight.grid % 4 == 0
    assert tight.per_cell >= MIN_PARTICLES_PER_CELL
    assert tight.dx == extent / (tight.grid - 14)
    assert tight.note and "grid lowered from 96" in tight.note
    assert tight.sample.count <= 1000
    # the grid is coarsened no further than needed: one step finer would be under the minimum
    finer = sample_on_grid(vertices, faces, extent, tight.grid + 4, 14, max_particles=1000, seed=2)
    assert finer.grid < tight.grid + 4


def test_a_grid_off_the_block_size_is_rounded_up_and_says_so(capsule):
    vertices, faces, *_ = capsule()
    extent = float(np.ptp(vertices, axis=0).max())
    placed = sample_on_grid(vertices, faces, extent, 30, 14, max_particles=None, seed=2)
    assert placed.grid == 32 and placed.dx == extent / (32 - 14)
    assert placed.note == "grid rounded up from 30 to 32 (multiple of the 4³ block)"
