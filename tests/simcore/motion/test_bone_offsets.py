"""Animated bone offsets: a clip that moves joints off their rigid bones (a head popping off, a second
character's root) plays exactly on the artist's own skeleton; a bone the target does not share stays rigid."""

from __future__ import annotations

import numpy as np

from simcore.motion.retarget import retarget
from simcore.motion.types import JointAnimation, MotionClip
from simcore.skeleton import kinematics
from simcore.skeleton.types import Skeleton


def _two_characters() -> Skeleton:
    """Under a scene root at the origin, character A: hips → chest → head; character B: body → arm."""
    pos = np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 1.4, 0.0], [0.0, 1.7, 0.0], [2.0, 1.0, 0.0], [2.3, 1.2, 0.0]])
    return Skeleton(pos, np.array([-1, 0, 1, 2, 0, 4]), ["scene", "hips", "chest", "head", "b_body", "b_arm"]).validate()


def _clip(skel: Skeleton, frames: int = 4) -> MotionClip:
    rest = kinematics.rest_local_matrices(skel)[:, :3, 3]
    tr = np.broadcast_to(rest, (frames, skel.num_joints, 3)).copy()
    lift = np.linspace(0.0, 0.6, frames)
    tr[:, 3, 1] += lift  # the head pops off its neck
    tr[:, 4, 0] += lift  # character B walks along +X
    tr[:, 1, 2] += lift  # character A walks along +Z
    rot = np.tile([0.0, 0.0, 0.0, 1.0], (frames, skel.num_joints, 1))
    anim = JointAnimation(list(skel.names), 30.0, rot, tr)
    return MotionClip(skel, anim, rest_is_standing=True, source_format="test", shares_bind_pose=True)


def _world(skel: Skeleton, anim: JointAnimation) -> np.ndarray:
    return kinematics.global_transforms(skel, kinematics.compose(anim.rotations, anim.translations))[..., :3, 3]


def test_the_artist_rig_plays_its_own_clip_exactly_with_several_characters_and_popping_joints():
    skel = _two_characters()
    clip = _clip(skel)
    out = retarget(clip, skel)
    assert np.allclose(_world(skel, out.animation), _world(skel, clip.animation), atol=1e-9)


def test_a_bone_whose_parent_follows_another_source_joint_stays_rigid():
    """A target without the source's chest: its head bone hangs off the hips, so the source's head offset
    (measured from the chest) is not carried and the head stays on its bone."""
    from simcore.options import MotionOptions

    source = _two_characters()
    target = Skeleton(np.array([[0.0, 1.0, 0.0], [0.0, 1.7, 0.0]]), np.array([-1, 0]), ["t_hips", "t_head"]).validate()
    out = retarget(_clip(source), target, MotionOptions(joint_map={"hips": "t_hips", "head": "t_head"}))
    world = _world(target, out.animation)
    assert np.allclose(world[:, 1] - world[:, 0], target.positions[1] - target.positions[0], atol=1e-9)
    assert np.allclose(world[:, 0, 2], np.linspace(0.0, 0.6, 4), atol=1e-9)  # the root motion still plays
