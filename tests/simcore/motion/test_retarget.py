"""Retargeting: identity, T-pose → A-pose, root scaling, options, joint mapping by names and structure."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from simcore.errors import InvalidInput
from simcore.io.bvh import parse_bvh
from simcore.motion.joint_map import joint_slot
from simcore.motion.retarget import map_joints, retarget
from simcore.motion.types import JointAnimation, MotionClip
from simcore.options import MotionOptions
from simcore.skeleton import kinematics
from simcore.skeleton.origin_root import origin_root
from simcore.skeleton.types import Skeleton
from tests.simcore.motion.motion_samples import bvh_text, humanoid


def _random_clip(skel: Skeleton, frames: int = 12, degrees: float = 30.0, seed: int = 0) -> MotionClip:
    rng = np.random.default_rng(seed)
    rot = Rotation.from_rotvec(rng.uniform(-1, 1, (frames * skel.num_joints, 3)) * np.deg2rad(degrees)).as_quat()
    trans = np.broadcast_to(kinematics.rest_local_matrices(skel)[:, :3, 3], (frames, skel.num_joints, 3)).copy()
    trans[:, 0] += np.linspace(0, 1, frames)[:, None] * [0.5, 0.1, 1.0]
    anim = JointAnimation(list(skel.names), 30.0, rot.reshape(frames, skel.num_joints, 4), trans, "random")
    return MotionClip(skel, anim, rest_is_standing=True, source_format="test")


def _world(skel: Skeleton, anim: JointAnimation) -> np.ndarray:
    return kinematics.global_transforms(skel, kinematics.compose(anim.rotations, anim.translations))


def test_identity_reproduces_world_joints():
    skel = humanoid()
    clip = _random_clip(skel)
    out = retarget(clip, skel)
    assert out.method == "names" and len(out.mapping) == skel.num_joints and out.root_scale == pytest.approx(1.0)
    assert np.allclose(_world(skel, out.animation)[..., :3, 3], _world(skel, clip.animation)[..., :3, 3], atol=1e-9)


def test_identity_with_oriented_joint_frames():
    base = humanoid()
    orient = Rotation.from_rotvec(np.random.default_rng(1).normal(size=(base.num_joints, 3))).as_quat()
    skel = Skeleton(base.positions, base.parents, base.names, base.kinds, orient)
    clip = _random_clip(skel, seed=2)
    out = retarget(clip, skel)
    want, got = _world(skel, clip.animation), _world(skel, out.animation)
    assert np.allclose(got[..., :3, 3], want[..., :3, 3], atol=1e-9)
    assert np.allclose(got[..., :3, :3], want[..., :3, :3], atol=1e-9)


def test_bvh_of_the_same_skeleton_gives_the_same_pose():
    skel = humanoid(prefix="")
    rng = np.random.default_rng(4)
    angles = rng.uniform(-40, 40, (6, skel.num_joints, 3))
    roots = np.array([[0.0, 1.0, 0.0]] * 6) + np.linspace(0, 1, 6)[:, None] * [1.0, 0.0, 0.0]
    clip = parse_bvh(bvh_text(skel, roots, angles, ["ZXY"] * skel.num_joints))
    target = humanoid()  # mixamorig: names
    out = retarget(clip, target)
    src, got = _world(clip.skeleton, clip.animation)[..., :3, 3], _world(target, out.animation)[..., :3, 3]
    src = src[:, [clip.skeleton.names.index(n.removeprefix("mixamorig:")) for n in target.names]]
    rel_src, rel_got = src - src[:, :1], got - got[:, :1]
    assert np.allclose(rel_got, rel_src, atol=1e-6)  # same pose about the hips
    assert np.allclose(got[:, 0, [0, 2]] - got[0, 0, [0, 2]], src[:, 0, [0, 2]] - src[0, 0, [0, 2]], atol=1e-6)


def test_t_pose_source_drives_a_pose_target():
    source, target = humanoid(0.0), humanoid(45.0)
    frames = 2
    rot = np.tile([0.0, 0.0, 0.0, 1.0], (frames, source.num_joints, 1))
    arm = source.names.index("mixamorig:LeftArm")
    rot[1, arm] = Rotation.from_rotvec([0, 0, np.deg2rad(60)]).as_quat()  # raise the left arm 60°
    trans = np.broadcast_to(kinematics.rest_local_matrices(source)[:, :3, 3], (frames, source.num_joints, 3)).copy()
    clip = MotionClip(source, JointAnimation(list(source.names), 30.0, rot, trans), rest_is_standing=True)
    out = retarget(clip, target)
    pos = _world(target, out.animation)[..., :3, 3]
    hand, shoulder = target.names.index("mixamorig:LeftHand"), arm
    for t, degrees in ((0, 0.0), (1, 60.0)):
        d = pos[t, hand] - pos[t, shoulder]
        assert np.degrees(np.arctan2(d[1], d[0])) == pytest.approx(degrees, abs=1e-6)
        assert np.linalg.norm(d) == pytest.approx(np.linalg.norm(target.positions[hand] - target.positions[shoulder]))
    # The right arm is not animated: it goes from the target's A-pose to the source's T-pose.
    r_hand, r_arm = target.names.index("mixamorig:RightHand"), target.names.index("mixamorig:RightArm")
    assert pos[0, r_hand, 1] == pytest.approx(pos[0, r_arm, 1], abs=1e-9)


def test_a_helper_root_at_the_origin_stays_still_and_is_no_foot():
    skel = humanoid()
    clip = _random_clip(skel)
    target, why = origin_root(skel, skel.positions, max_joints=64)
    assert why == "added at the file's origin"
    out = retarget(clip, target)
    world = _world(target, out.animation)[..., :3, 3]
    assert np.allclose(world[:, 0], 0.0) and target.names[0] not in out.contact_joints and target.names[0] not in out.mapping
    assert np.allclose(world[:, 1:], _world(skel, clip.animation)[..., :3, 3], atol=1e-9)


def test_root_motion_scales_with_hip_height_and_feet_stay_down():
    source, target = humanoid(), humanoid(scale=2.0)
    clip = _random_clip(source, degrees=0.0)
    out = retarget(clip, target)
    assert out.root_scale == pytest.approx(2.0)
    src, got = _world(source, clip.animation)[..., :3, 3], _world(target, out.animation)[..., :3, 3]
    assert np.allclose(got[:, 0, [0, 2]] - target.positions[0, [0, 2]], 2 * (src[:, 0, [0, 2]] - source.positions[0, [0, 2]]))
    feet = [target.names.index(n) for n in out.contact_joints]
    lift = src[:, feet, 1].min(axis=1) - source.positions[feet, 1].min()  # the clip rises 0.1 m over time
    assert np.allclose(got[:, feet, 1].min(axis=1), target.positions[feet, 1].min() + 2 * lift, atol=1e-9)


def test_options_in_place_fps_range_loop():
    skel = humanoid()
    clip = _random_clip(skel, frames=31)  # 1 s at 30 fps
    out = retarget(clip, skel, MotionOptions(in_place=True, fps=10, start=0.2, end=0.8, loop=True))
    assert out.animation.num_frames == 7 and out.animation.fps == 10 and out.animation.loop
    root = _world(skel, out.animation)[:, 0, :3, 3]
    assert np.allclose(root[:, [0, 2]], skel.positions[0, [0, 2]])
    with pytest.raises(InvalidInput) as err:
        retarget(clip, skel, MotionOptions(start=5.0))
    assert err.value.field == "motion.start"


def test_cmu_names_map_to_mixamo(dev_assets):
    clip = parse_bvh((dev_assets / "mocap_cmu_01_01.bvh").read_bytes())
    mapping, method, turns = map_joints(clip.skeleton, humanoid())
    named = {humanoid().names[t].removeprefix("mixamorig:"): clip.skeleton.names[s] for t, s in mapping.items()}
    assert method == "names" and turns == 0
    assert named["Hips"] == "Hips" and named["LeftUpLeg"] == "LeftUpLeg" and named["RightFoot"] == "RightFoot"
    assert named["LeftShoulder"] == "LeftShoulder" and named["LeftArm"] == "LeftArm" and named["Head"] == "Head"
    assert named["Spine"] == "LowerBack" and named["Spine2"] == "Spine1" and named["Neck"] == "Neck"
    assert "LHipJoint" not in named.values()


@pytest.mark.parametrize("name, slot", [
    ("mixamorig:LeftForeArm", "LeftForeArm"), ("upperarm_l", "LeftArm"), ("calf_r", "RightLeg"), ("J_Bip_L_UpperArm", "LeftArm"),
    ("LeftUpperLeg", "LeftUpLeg"), ("rShldr", "RightArm"), ("lThigh", "LeftUpLeg"), ("clavicle_r", "RightShoulder"),
    ("LeftKnee", "LeftLeg"), ("pelvis", "Hips"), ("spine_02", "spine"), ("LHipJoint", None), ("index_02_l", "LeftHandIndex2"),
    ("UpperArm.R", "RightArm"), ("Head", "Head"), ("tail_03", None),
])
def test_joint_slots(name, slot):
    assert joint_slot(name) == slot


def test_collar_makes_shoulder_the_upper_arm():
    skel = humanoid(prefix="")
    names = [n.replace("LeftShoulder", "LeftCollar").replace("LeftArm", "LeftShoulder") for n in skel.names]
    source = Skeleton(skel.positions, skel.parents, names)
    mapping, _, _ = map_joints(source, humanoid())
    target = humanoid()
    got = {target.names[t]: names[s] for t, s in mapping.items()}
    assert got["mixamorig:LeftShoulder"] == "LeftCollar" and got["mixamorig:LeftArm"] == "LeftShoulder"


def test_unnamed_skeleton_maps_by_chains_and_overrides_win():
    target = humanoid()
    anonymous = Skeleton(target.positions @ Rotation.from_rotvec([0, np.pi / 2, 0]).as_matrix().T, target.parents,
                         [f"j{k}" for k in range(target.num_joints)])
    mapping, method, turns = map_joints(anonymous, target)
    assert method == "chains" and turns in (1, 3)
    assert all(mapping[t] == t for t in mapping) and len(mapping) >= 18
    mapping, method, _ = map_joints(anonymous, target, {"j5": "mixamorig:Neck"})
    assert mapping[4] == 5 and method.endswith("+overrides")
    with pytest.raises(InvalidInput) as err:
        map_joints(anonymous, target, {"nope": "mixamorig:Neck"})
    assert err.value.field == "motion.joint_map"



def _hip_rig(hip, spine, legs, tail) -> Skeleton:  # noqa: ANN001 - (3,) positions of a four-legged hip fan
    pos = np.array([hip, spine, [legs[0], *legs[1:]], [-legs[0], *legs[1:]], tail], dtype=np.float64)
    ends = pos[1:] + [[0, 0, 0.15], [0, -0.3, 0], [0, -0.3, 0], [0, 0, -0.2]]
    return Skeleton(np.vstack([pos, ends]), np.array([-1, 0, 0, 0, 0, 1, 2, 3, 4]),
                    ["hip", "spine", "leg_l", "leg_r", "tail", "chest", "knee_l", "knee_r", "tail_tip"]).validate()


def test_hip_whose_bones_fan_out_differently_is_not_turned_at_rest():
    """The fox's case: the artist's hip sits low in the pelvis (spine, legs and tail leave it upwards), ours on
    the body's medial line (spine forward, legs down). No one rotation fits those bones, so the hip is not
    turned to fit them: at the source's rest pose the target stays at its own rest (it collapsed the waist)."""
    source = _hip_rig([0, 0.43, -0.27], [0, 0.55, -0.22], [0.07, 0.49, -0.30], [0, 0.53, -0.40])
    target = _hip_rig([0, 0.47, -0.20], [0, 0.48, -0.02], [0.063, 0.39, -0.27], [0, 0.475, -0.30])
    rest = np.broadcast_to(kinematics.rest_local_matrices(source)[:, :3, 3], (2, source.num_joints, 3)).copy()
    still = JointAnimation(list(source.names), 30.0, np.tile([0.0, 0.0, 0.0, 1.0], (2, source.num_joints, 1)), rest)
    options = MotionOptions(joint_map={n: n for n in source.names})
    out = retarget(MotionClip(source, still, rest_is_standing=True, source_format="test"), target, options)
    hip = _world(target, out.animation)[:, 0, :3, :3]
    assert np.allclose(hip, np.eye(3), atol=1e-9)
