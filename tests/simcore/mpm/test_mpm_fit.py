import dataclasses

import numpy as np
import pytest

from simcore.mpm.fit import FitConfig, PhysicsFit, driver_path, prepare_scene
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


@pytest.mark.parametrize("drive", ["velocity", "anchored"])
def test_velocity_fit_reduces_the_chamfer_loss(drive):
    config = FitConfig(prototypes=2, grid=24, substeps=10, max_particles=800, drive=drive)
    vertices, faces = synthetic_bar(8)
    scene = prepare_scene(np.repeat(vertices[None], 3, axis=0), faces, 25.0, config,
                          driver_centres=np.array([[-0.42, 0.0, 0.0]]))
    truth = np.zeros_like(scene.velocities)
    truth[..., 1] = 0.6  # cells per frame, upward
    targets = PhysicsFit(driver_path(scene, truth), config).simulate()
    fit = PhysicsFit(dataclasses.replace(driver_path(scene, truth * 0.3), targets=targets), config)
    before = fit.velocity_phase(1, 0.0)
    after = fit.velocity_phase(5, 0.02)
    assert after < 0.8 * before
    # moved toward the generating path: the velocity itself, or (anchored) a correction of the end anchor upward
    assert fit.controls[0, :, 1].mean() > (0.3 * 0.6 if drive == "velocity" else 0.0)


def test_a_velocity_phase_never_ends_worse_than_it_started():
    """A learning rate far too large for the grid: the phase is undone rather than left worse."""
    config = FitConfig(prototypes=2, grid=24, substeps=10, max_particles=800)
    vertices, faces = synthetic_bar(8)
    scene = prepare_scene(np.repeat(vertices[None], 3, axis=0), faces, 25.0, config,
                          driver_centres=np.array([[-0.42, 0.0, 0.0]]))
    truth = np.zeros_like(scene.velocities)
    truth[..., 1] = 0.6
    targets = PhysicsFit(driver_path(scene, truth), config).simulate()
    fit = PhysicsFit(dataclasses.replace(driver_path(scene, truth * 0.3), targets=targets), config)
    before = fit.velocity_phase(1, 0.0)
    after = fit.velocity_phase(3, 50.0)
    assert after <= before * (1 + 1e-9)
    assert np.isfinite(fit.controls).all()


def test_anchored_drive_does_not_accumulate_a_velocity_error():
    """Driving points aimed at per-frame anchors stay within a cell of them; integrated velocities with a bias
    drift further every frame."""
    frames = 6
    vertices, faces = synthetic_bar(8)
    base = FitConfig(prototypes=2, grid=24, substeps=10, max_particles=800)
    scene = prepare_scene(np.repeat(vertices[None], frames, axis=0), faces, 25.0, base,
                          driver_centres=np.array([[-0.42, 0.0, 0.0]]))
    path = np.zeros_like(scene.velocities)
    path[..., 1] = 0.5
    scene = driver_path(scene, path)
    assert scene.anchors is not None and scene.driver_particles is not None
    gaps = {}
    for drive in ("velocity", "anchored"):
        fit = PhysicsFit(scene, dataclasses.replace(base, drive=drive))
        fit.controls += 0.2 if drive == "velocity" else 0.0  # a velocity error of 0.2 cells per frame
        xs = fit.simulate()
        assert np.all(np.isfinite(xs))
        end = fit.rollout.checkpoints[frames - 1].x.numpy().astype(np.float64)
        embed = scene.driver_particles
        carried = scene.drivers0 + end[embed].mean(1) - scene.x0[embed].mean(1)
        gaps[drive] = float(np.linalg.norm(carried - scene.anchors[-1], axis=1).mean()) / scene.dx
    assert gaps["anchored"] < 0.5
    assert gaps["velocity"] > 2 * gaps["anchored"]


def test_joint_motions_recover_a_rigid_turn():
    from scipy.spatial.transform import Rotation

    from simcore.mpm.anchors import joint_motions

    rng = np.random.default_rng(1)
    rest = rng.normal(size=(50, 3))
    r = Rotation.from_rotvec([0.1, 0.4, -0.2]).as_matrix()
    moved = rest @ r.T + [0.3, -0.1, 0.2]
    rot, trans = joint_motions(np.stack([rest, moved]), np.ones((50, 1)))
    np.testing.assert_allclose(rot[1, 0], r, atol=1e-9)
    np.testing.assert_allclose(rest @ rot[1, 0].T + trans[1, 0], moved, atol=1e-9)


def test_prototype_mixing_is_differentiable_in_the_geometry():
    import torch

    config = FitConfig(prototypes=3, grid=24, substeps=4, max_particles=600, drivers="virtual", virtual_joints=2)
    vertices, faces = synthetic_bar(8)
    scene = prepare_scene(np.repeat(vertices[None], 2, axis=0), faces, 25.0, config)
    fit = PhysicsFit(scene, config)
    theta = torch.tensor([0.0, 2.0, -2.0], dtype=torch.float64)  # distinct E, so moving a prototype changes E(x)
    geometry = {k: torch.tensor(v, requires_grad=True) for k, v in fit.geometry.items()}
    rng = np.random.default_rng(0)
    probe = torch.as_tensor(rng.normal(size=len(scene.x0)))
    (probe * fit.particle_E(theta, geometry)).sum().backward()
    assert geometry["centres"].grad is not None
    grad = geometry["centres"].grad.numpy()
    assert np.abs(grad).max() > 0
    eps = 1e-5
    moved = {k: v.detach().clone() for k, v in geometry.items()}
    moved["centres"][1, 0] += eps
    with torch.no_grad():
        fd = ((probe * fit.particle_E(theta, moved)).sum() - (probe * fit.particle_E(theta, geometry)).sum()) / eps
    assert abs(float(fd) - grad[1, 0]) < 1e-3 * max(1.0, abs(grad[1, 0]))


def test_lbs_test_phase_keeps_the_trained_weights():
    from simcore.mpm.lbs_fit import fit_lbs

    vertices, _ = synthetic_bar(6)
    targets = np.stack([vertices + [0.0, 0.02 * t, 0.0] for t in range(4)])
    centres = np.array([[-0.3, 0.0, 0.0], [0.3, 0.0, 0.0]])
    _, logits = fit_lbs(targets[:2], centres, 5, scale=0.05)
    frames, kept = fit_lbs(targets, centres, 20, scale=0.05, frozen_logits=logits, first=1)
    assert np.array_equal(kept, logits)
    before = np.abs(targets[3] - targets[0]).mean()
    assert np.abs(frames[3] - targets[3]).mean() < before  # the held-out frames' transforms were fitted


def test_initial_motion_follows_a_body_that_is_already_moving():
    """A bar gliding at constant speed: starting the particles with their joints' motion keeps it on the targets,
    starting at rest makes the undriven material lag the driving points."""
    from simcore.mpm.fit import initial_velocities, per_frame_chamfer

    vertices, faces = synthetic_bar(8)
    targets = np.stack([vertices + [0.0, 0.03 * t, 0.0] for t in range(3)])
    errors = {}
    for moving in (True, False):
        config = FitConfig(prototypes=2, grid=24, substeps=10, max_particles=800, drivers="virtual", virtual_joints=2,
                           initial_motion=moving)
        scene = prepare_scene(targets, faces, 25.0, config)
        if moving:
            np.testing.assert_allclose(initial_velocities(scene), np.tile([0.0, 0.03 * 25.0, 0.0], (len(scene.x0), 1)),
                                       atol=1e-9)
        errors[moving] = per_frame_chamfer(PhysicsFit(scene, config).simulate(), targets)[1:].mean()
    assert errors[True] < 0.5 * errors[False]
