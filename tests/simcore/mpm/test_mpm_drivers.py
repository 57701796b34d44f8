import numpy as np
from scipy.spatial.transform import Rotation

from simcore.mpm.drivers import PER_JOINT, animation_world_transforms, leaf_tips, place_drivers, substep_drive


def test_eight_driving_points_per_joint_in_both_modes(capsule):
    vertices, _, skeleton, weights, _ = capsule()
    for mode in ("joints", "bones"):
        drivers = place_drivers(skeleton, mode, 0.05, tips=leaf_tips(skeleton, vertices, weights))
        assert drivers.count == PER_JOINT * skeleton.num_joints
        assert np.bincount(drivers.joints).tolist() == [PER_JOINT] * skeleton.num_joints
    bones = place_drivers(skeleton, "bones", 0.05, tips=leaf_tips(skeleton, vertices, weights))
    # bone cores: the root's points lie on the segment root → mid (x = z = 0)
    assert np.allclose(bones.rest[bones.joints == 0][:, [0, 2]], 0.0)


def test_substep_velocities_integrate_to_the_skeleton_motion(capsule):
    vertices, _, skeleton, weights, animation = capsule(bend_degrees=60.0, frames=3)
    drivers = place_drivers(skeleton, "bones", 0.05)
    world = animation_world_transforms(skeleton, animation)
    substeps, dt = 50, (1 / animation.fps) / 50
    dp, dv = substep_drive(drivers, world[1], world[2], substeps, dt)
    end = dp[-1] + dv[-1] * dt
    target = np.einsum("dab,db->da", world[2][drivers.joints][:, :3, :3], drivers.offsets) + world[2][drivers.joints][:, :3, 3]
    np.testing.assert_allclose(end, target, atol=1e-5)
    # rotations are slerped, so a point on the rotating bone keeps its distance to the pivot
    pivot = skeleton.positions[1]
    r = np.linalg.norm(dp[:, drivers.joints == 1] - pivot, axis=2)
    np.testing.assert_allclose(r, r[:1].repeat(len(r), axis=0), atol=1e-5)
    assert Rotation.from_matrix(world[2][1, :3, :3]).magnitude() > 0.5  # the clip really bends
