import dataclasses

import numpy as np

from simcore.mpm.fit import FitConfig, PhysicsFit, prepare_scene
from simcore.mpm.fit_experiment import synthetic_bar
from simcore.mpm.measures import chamfer_grad


def test_chamfer_gradient_matches_finite_differences():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(30, 3)), rng.normal(size=(40, 3))
    loss, grad = chamfer_grad(a, b)
    eps = 1e-6
    bumped = a.copy()
    bumped[3, 1] += eps
    assert abs((chamfer_grad(bumped, b)[0] - loss) / eps - grad[3, 1]) < 1e-4


def test_velocity_fit_reduces_the_chamfer_loss():
    config = FitConfig(prototypes=2, grid=24, substeps=10, max_particles=800)
    vertices, faces = synthetic_bar(8)
    scene = prepare_scene(np.repeat(vertices[None], 3, axis=0), faces, 25.0, config,
                          driver_centres=np.array([[-0.42, 0.0, 0.0]]))
    truth = np.zeros_like(scene.velocities)
    truth[..., 1] = 0.6  # cells per frame, upward
    targets = PhysicsFit(dataclasses.replace(scene, velocities=truth), config).simulate()
    fit = PhysicsFit(dataclasses.replace(scene, targets=targets, velocities=truth * 0.3), config)
    before = fit.velocity_phase(1, 0.0)
    after = fit.velocity_phase(5, 0.02)
    assert after < 0.8 * before
    assert fit.velocities[0, :, 1].mean() > 0.3 * 0.6  # moved toward the generating velocity
