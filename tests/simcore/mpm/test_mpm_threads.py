"""The CPU solver's particle passes split over threads give the single-thread result (to float rounding)."""

import numpy as np
import pytest

wp = pytest.importorskip("warp")


def _run(threads: int, steps: int = 12) -> tuple[np.ndarray, tuple[int, int]]:
    from simcore.mpm.materials import lame
    from simcore.mpm.solver import MPMSolver, SubstepInputs

    rng = np.random.default_rng(1)
    d = rng.normal(size=(3001, 3))  # odd count: the two ranges differ in size
    x = 0.5 + 0.15 * d / np.linalg.norm(d, axis=1, keepdims=True) * rng.uniform(0, 1, (len(d), 1)) ** (1 / 3)
    solver = MPMSolver(len(x), 32, 1 / 32, 1e-3, 1e-6, device="cpu", gravity=(0, -9.8, 0), threads=threads)
    mu, lam = lame(2e4, 0.4)
    inp = SubstepInputs(wp.full(len(x), float(mu), dtype=float, device="cpu"),
                        wp.full(len(x), float(lam), dtype=float, device="cpu"), (0.0, 0.0, 0.0), 1e-3,
                        wp.array(np.array([[0.5, 0.5, 0.5]], np.float32), dtype=wp.vec3, device="cpu"),
                        wp.array(np.array([[0.0, 40.0, 0.0]], np.float32), dtype=wp.vec3, device="cpu"))
    a, b = solver.new_state(x), solver.new_state()
    a.v.assign(np.cross([0.0, 3.0, 1.0], x - 0.5).astype(np.float32))
    for _ in range(steps):
        solver.substep(a, b, inp)
        a, b = b, a
    return a.x.numpy(), solver.take_clamp_counts()


def test_two_threads_match_one_thread():
    one, clamps_one = _run(1)
    two, clamps_two = _run(2)
    assert np.abs(one - one[0]).max() > 1e-3  # the ball moved and deformed: the comparison is not vacuous
    assert np.abs(one - two).max() < 1e-5
    assert clamps_one == clamps_two and clamps_one[0] > 0  # the driver's 40 m/s is clamped in both, counted once


def test_threads_are_refused_for_a_differentiable_solver():
    from simcore.mpm.solver import MPMSolver

    with pytest.raises(ValueError, match="forward-only"):
        MPMSolver(10, 16, 1 / 16, 1e-3, 1e-6, device="cpu", requires_grad=True, threads=2)
    assert MPMSolver(10, 16, 1 / 16, 1e-3, 1e-6, device="cpu", requires_grad=True).threads == 1
