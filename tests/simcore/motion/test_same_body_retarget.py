"""Retargeting onto a skeleton built in the same body: no rest alignment, one pivot per source joint, joints
mapped by where their bones lie."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.spatial.transform import Rotation

from simcore.motion.body_map import branch_candidates, fill_by_region, flesh_shares, region_mapping
from simcore.motion.retarget import map_joints, one_pivot_per_source_joint, retarget
from simcore.motion.types import JointAnimation, MotionClip
from simcore.skeleton import kinematics
from simcore.skeleton.origin_root import origin_root
from simcore.skeleton.types import Skeleton


def _still(skel: Skeleton, frames: int = 2) -> JointAnimation:
    rest = np.broadcast_to(kinematics.rest_local_matrices(skel)[:, :3, 3], (frames, skel.num_joints, 3)).copy()
    return JointAnimation(list(skel.names), 30.0, np.tile([0.0, 0.0, 0.0, 1.0], (frames, skel.num_joints, 1)), rest)


def _world(skel: Skeleton, anim: JointAnimation) -> np.ndarray:
    return kinematics.global_transforms(skel, kinematics.compose(anim.rotations, anim.translations))


def _leg(foot_to_toe: list[float], hip_height: float, names: list[str]) -> Skeleton:
    """hip → knee → ankle → toe, the toe placed at `foot_to_toe` from the ankle."""
    hip = np.array([0.0, hip_height, 0.0])
    pos = np.array([hip, [0.0, 0.5, 0.02], [0.0, 0.1, 0.0], np.add([0.0, 0.1, 0.0], foot_to_toe)])
    return Skeleton(pos, np.array([-1, 0, 1, 2]), names).validate()


def test_shared_bind_pose_keeps_the_target_rest_and_root_scale():
    """Two rigs of one leg whose toe joints sit differently (placement, not pose): at the source's rest the
    target stays at its own rest, and root motion is not rescaled by the hip heights' ratio."""
    source = _leg([0.0, -0.06, 0.03], 0.95, ["a", "b", "c", "d"])  # toe steeply below the ankle
    target = _leg([0.0, -0.03, 0.10], 0.90, ["p", "q", "r", "s"])  # toe forward
    anim = _still(source, 3)
    anim.translations[:, 0] += np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.5], [0.0, 0.0, 1.0]])  # walks 1 m along +Z
    clip = MotionClip(source, anim, rest_is_standing=True, source_format="test")
    overrides = {"a": "p", "b": "q", "c": "r", "d": "s"}
    from simcore.options import MotionOptions

    shared = retarget(replace(clip, shares_bind_pose=True), target, MotionOptions(joint_map=overrides))
    world = _world(target, shared.animation)
    assert np.allclose(world[:, :, :3, :3], np.eye(3), atol=1e-9)  # nothing turned
    assert shared.root_scale == 1.0
    assert np.allclose(world[:, 0, 2, 3], [0.0, 0.5, 1.0], atol=1e-9)
    # Without the flag the ankle is turned at rest to point the foot like the source's (what bent the ankles).
    aligned = _world(target, retarget(clip, target, MotionOptions(joint_map=overrides)).animation)
    assert not np.allclose(aligned[0, 2, :3, :3], np.eye(3), atol=1e-3)


def _strip(ys: list[float], prefix: str) -> Skeleton:
    pos = np.array([[0.0, y, 0.0] for y in ys])
    return Skeleton(pos, np.arange(len(ys)) - 1, [f"{prefix}{k}" for k in range(len(ys))]).validate()


def test_region_mapping_bends_where_the_source_bends():
    """A two-joint source bending at y = 1 and a five-joint target along the same strip: the target joint at the
    bend takes the source's second joint; the target leaf alone would bend the strip half a unit too high."""
    source, target = _strip([0.0, 1.0], "s"), _strip([0.5, 0.75, 1.01, 1.26, 1.5], "t")
    mapping = fill_by_region(source, target, {0: 0, 4: 1})
    assert mapping == {0: 0, 1: 0, 2: 1, 3: 1, 4: 1}
    # Each shared source joint's nearest target joint is the shallowest of its group: nothing to drop.
    assert one_pivot_per_source_joint(source, target, mapping, 0, same_body=True) == mapping
    frames = 2
    rot = np.tile([0.0, 0.0, 0.0, 1.0], (frames, 2, 1))
    rot[1, 1] = Rotation.from_rotvec([0.0, 0.0, np.pi / 2]).as_quat()
    anim = JointAnimation(["s0", "s1"], 30.0, rot, np.broadcast_to(kinematics.rest_local_matrices(source)[:, :3, 3], (frames, 2, 3)).copy())
    clip = MotionClip(source, anim, rest_is_standing=True, source_format="test", shares_bind_pose=True)
    out = retarget(clip, target)
    pos = _world(target, out.animation)[1, :, :3, 3]
    assert np.allclose(pos[:3], target.positions[:3], atol=1e-9)  # below the bend nothing moves
    assert pos[4, 0] == pytest.approx(-(1.5 - 1.01), abs=1e-9)  # above it the strip turns about the joint at 1.01


def test_clavicle_mapped_with_the_arm_stays_with_the_chest():
    """Shoulder and arm joints of the target both on the source's arm joint: only the arm turns with it."""
    source = Skeleton(np.array([[0.0, 1.0, 0.0], [0.2, 1.0, 0.0], [0.5, 1.0, 0.0]]), np.array([-1, 0, 1]),
                      ["chest", "arm", "hand"]).validate()
    target = Skeleton(np.array([[0.0, 1.0, 0.0], [0.05, 1.0, 0.0], [0.19, 1.0, 0.0], [0.5, 1.0, 0.0]]),
                      np.array([-1, 0, 1, 2]), ["t_chest", "t_clav", "t_arm", "t_hand"]).validate()
    assert one_pivot_per_source_joint(source, target, {0: 0, 1: 1, 2: 1, 3: 2}, 0) == {0: 0, 2: 1, 3: 2}
    assert map_joints(source, target)[0].get(1) != 1  # as the structural mapping gives it


def test_feet_hanging_off_a_floor_root_keep_the_floor():
    """An IK-style source: the feet hang off a floor root, outside the body that carries the root motion. The
    body drops 0.2 while the feet stay down: our feet stay on the floor too (not 0.2 below it, as the lowest
    joint of the body's subtree, the knee, would have them)."""
    source = Skeleton(np.array([[0.0, 0.0, -0.5], [0.0, 1.0, 0.0], [0.0, 0.5, 0.02], [0.0, 0.05, 0.0], [0.0, 0.02, 0.15]]),
                      np.array([-1, 0, 1, 0, 3]), ["floor", "body", "knee", "foot", "toe"]).validate()
    target = Skeleton(np.array([[0.0, 1.0, 0.0], [0.0, 0.5, 0.02], [0.0, 0.05, 0.0], [0.0, 0.02, 0.15]]), np.array([-1, 0, 1, 2]),
                      ["t_hip", "t_knee", "t_foot", "t_toe"]).validate()
    anim = _still(source, 3)
    anim.translations[:, 1, 1] -= np.array([0.0, 0.1, 0.2])  # the body crouches; the foot's own key stays put
    clip = MotionClip(source, anim, rest_is_standing=True, source_format="test", shares_bind_pose=True)
    out = retarget(clip, target)
    assert out.mapping["t_foot"] == "foot" and out.contact_joints == ["t_foot", "t_toe"]
    feet = _world(target, out.animation)[:, 2, 1, 3]
    assert np.allclose(feet, 0.05, atol=1e-9)


def test_a_branching_joint_takes_the_joint_where_its_branches_meet():
    """A quadruped's chest: our hub sits off-centre, nearest the source's left leg bone, but its branches (both
    front legs and the neck) map into three source branches that meet at the chest: the hub takes the chest,
    so the chest no longer swings with one leg."""
    source = Skeleton(np.array([[0.0, 1.0, -0.5], [0.0, 1.0, 0.0], [0.1, 0.95, 0.05], [0.1, 0.5, 0.05], [-0.1, 0.95, 0.05],
                                [-0.1, 0.5, 0.05], [0.0, 1.2, 0.3], [0.0, 1.4, 0.5]]), np.array([-1, 0, 1, 2, 1, 4, 1, 6]),
                      ["spine", "chest", "leg_l", "foot_l", "leg_r", "foot_r", "neck", "head"]).validate()
    target = Skeleton(np.array([[0.0, 1.0, -0.5], [0.08, 0.9, 0.05], [0.1, 0.6, 0.05], [-0.1, 0.6, 0.05], [0.0, 1.3, 0.4]]),
                      np.array([-1, 0, 1, 1, 1]), ["t_spine", "t_hub", "t_l", "t_r", "t_neck"]).validate()
    mapping = region_mapping(source, target)
    assert [source.names[mapping[j]] for j in range(5)] == ["spine", "chest", "leg_l", "leg_r", "neck"]
    assert branch_candidates(source.parents, [3, 5, 7]) == [1, 0]  # the chest and the spine above it
    assert branch_candidates(source.parents, [3, 5, 0]) == [1, 0]  # a child mapped up the tree does not count
    assert branch_candidates(source.parents, [3, 2]) == []  # one branch going down


def test_our_root_swings_with_the_source_joint_it_follows_about_that_joints_place():
    """Our root sits 0.7 above the source's hip it follows (a chest-high hub). The hip tips 30° forward: our root
    moves as the point at its place on the hip does (forward and down), not turning in place."""
    source = _strip([1.0, 1.5], "s")
    target = _strip([1.7, 2.0], "t")
    frames = 2
    rot = np.tile([0.0, 0.0, 0.0, 1.0], (frames, 2, 1))
    rot[1, 0] = Rotation.from_rotvec([np.pi / 6, 0.0, 0.0]).as_quat()
    anim = JointAnimation(["s0", "s1"], 30.0, rot, np.broadcast_to(kinematics.rest_local_matrices(source)[:, :3, 3], (frames, 2, 3)).copy())
    clip = MotionClip(source, anim, rest_is_standing=True, source_format="test", shares_bind_pose=True)
    from simcore.options import MotionOptions

    out = retarget(clip, target, MotionOptions(joint_map={"s0": "t0", "s1": "t1"}))
    root = _world(target, out.animation)[1, 0, :3, 3]
    expected = Rotation.from_rotvec([np.pi / 6, 0.0, 0.0]).apply([0.0, 0.7, 0.0]) + [0.0, 1.0, 0.0]
    assert np.allclose(root[[0, 2]], expected[[0, 2]], atol=1e-9)  # the ground correction may move it up or down only


def test_a_joint_between_two_characters_keeps_the_nearest_bones():
    """Two characters side by side under a scene root far below them: a target joint whose branches run into
    both meets them only at that scene root, out of its reach, so it keeps the body whose bones lie nearest."""
    pos = [[0.0, -3.0, 0.0], [0.0, -3.0, 0.0], [-0.3, 1.0, 0.0], [-0.6, 1.0, 0.0], [-0.9, 1.0, 0.0],
           [0.0, -3.0, 0.0], [0.35, 1.0, 0.0], [0.6, 1.0, 0.0], [0.9, 1.0, 0.0]]
    source = Skeleton(np.array(pos), np.array([-1, 0, 1, 2, 3, 0, 5, 6, 7]),
                      ["scene", "holder_a", "body_a", "arm_a", "hand_a", "holder_b", "body_b", "arm_b", "hand_b"]).validate()
    target = Skeleton(np.array([[0.0, 1.0, 0.0], [-0.45, 1.0, 0.0], [-0.9, 1.0, 0.0], [0.45, 1.0, 0.0], [0.9, 1.0, 0.0]]),
                      np.array([-1, 0, 1, 0, 3]), ["t_hub", "t_a", "t_a2", "t_b", "t_b2"]).validate()
    mapping = region_mapping(source, target)
    assert source.names[mapping[1]] == "arm_a" and source.names[mapping[3]] == "arm_b"
    assert source.names[mapping[0]] == "body_a"  # not the scene root both arms meet at


def test_a_target_root_sharing_its_source_joint_with_its_child_is_carried_by_it():
    """Our root and its only child both lie on the source joint that turns (a skeleton built inside the head of a
    creature whose root sits at its feet): the root must not be dropped as a chain link, or nothing carries it and
    the flesh it holds stays behind while the head turns. All of ours turns rigidly with the source joint."""
    source = _strip([0.0, 1.0], "s")
    target = _strip([0.9, 1.05, 1.5], "t")
    assert one_pivot_per_source_joint(source, target, {0: 1, 1: 1, 2: 1}, 0, same_body=True) == {0: 1, 1: 1, 2: 1}
    frames = 2
    rot = np.tile([0.0, 0.0, 0.0, 1.0], (frames, 2, 1))
    turn = Rotation.from_rotvec([0.0, 0.0, np.pi / 2])
    rot[1, 1] = turn.as_quat()
    anim = JointAnimation(["s0", "s1"], 30.0, rot, np.broadcast_to(kinematics.rest_local_matrices(source)[:, :3, 3], (frames, 2, 3)).copy())
    clip = MotionClip(source, anim, rest_is_standing=True, source_format="test", shares_bind_pose=True)
    from simcore.options import MotionOptions

    out = retarget(clip, target, MotionOptions(joint_map={"s1": "t0"}))
    pivot = np.array([0.0, 1.0, 0.0])
    expected = pivot + turn.apply(target.positions - pivot)
    world = _world(target, out.animation)[1]
    np.testing.assert_allclose(world[:, :3, :3], np.broadcast_to(turn.as_matrix(), (3, 3, 3)), atol=1e-9)
    # Rigid with the source joint; the floor correction may lift the whole pose, so compare from the root.
    np.testing.assert_allclose(world[:, :3, 3] - world[0, :3, 3], expected - expected[0], atol=1e-9)
    assert world[0, 0, 3] == pytest.approx(expected[0, 0], abs=1e-9)  # the root swung out with the head


def test_a_bone_equally_near_two_source_bones_takes_the_one_lying_towards_it():
    """A target bone in the wedge outside a source joint is nearest that joint's head on both the source bone
    ending there and the one starting there: the tie goes to the bone whose middle lies nearer, the same way in
    every placement of the pair (without a tie-break, rounding chose differently from one placement to the next)."""
    source = Skeleton(np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 2.0, 0.0]]), np.array([-1, 0, 1]),
                      ["body", "leg", "foot"]).validate()
    target = Skeleton(np.array([[0.0, 0.0, 0.0], [-1.0, 1.5, 0.0], [-2.0, 2.0, 0.0]]), np.array([-1, 0, 1]),
                      ["root", "extra", "extra_end"]).validate()
    chosen = set()
    for seed in range(40):
        turn = Rotation.random(random_state=seed).as_matrix()
        shift = np.random.default_rng(seed).normal(size=3) * 10.0
        moved_source, moved_target = (Skeleton(s.positions @ turn.T + shift, s.parents, s.names).validate()
                                      for s in (source, target))
        chosen.add(region_mapping(moved_source, moved_target)[1])
    assert chosen == {0}  # body's middle (0, 0.5) lies nearer the extra bone than leg's (0.5, 1.5)


def test_a_bone_out_in_flesh_its_source_joint_moves_follows_that_joint():
    """A target bone standing out in flesh the artist bound to a body joint whose bone lies farther away than a
    leg's (a mech's cockpit): given both skins, it follows the body joint; without them, the nearer leg."""
    source = Skeleton(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]), np.array([-1, 0, 1]),
                      ["body", "leg", "foot"]).validate()
    target = Skeleton(np.array([[0.0, 0.0, 0.0], [1.5, 1.0, 0.0], [1.8, 1.0, 0.0]]), np.array([-1, 0, 1]),
                      ["root", "cockpit", "cockpit_end"]).validate()
    ours = sp.csr_matrix(np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]))
    artist = sp.csr_matrix(np.array([[1.0, 0.0, 0.0], [0.9, 0.1, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]))
    assert region_mapping(source, target)[1] == 1
    assert region_mapping(source, target, flesh_shares(ours, artist))[1] == 0
    anim = _still(source)
    clip = MotionClip(source, anim, rest_is_standing=True, source_format="test", shares_bind_pose=True, bind_weights=artist)
    assert retarget(clip, target, target_weights=ours).mapping["cockpit"] == "body"
    assert retarget(clip, target).mapping["cockpit"] == "leg"


def test_a_helper_root_neither_poisons_the_region_map_nor_moves():
    """A joint that owns no bone (a helper root at the origin) gets a finite region cost from its position; it used
    to make every cost NaN and map every joint to the source's root. The body maps as without it, and a same-body
    clip leaves the helper where it is."""
    source, body = _strip([0.0, 1.0], "s"), _strip([0.5, 0.75, 1.01, 1.26, 1.5], "t")
    rooted, why = origin_root(body, body.positions, max_joints=64)
    assert why == "added at the file's origin"
    shares = np.ones((rooted.num_joints, source.num_joints))  # flesh each joint moves (`flesh_shares`)...
    shares[0] = 0.0  # ...none for the helper
    expected = {0: 0, **{k + 1: v for k, v in region_mapping(source, body, shares[1:]).items()}}
    assert region_mapping(source, rooted, shares) == expected and expected[5] == 1
    frames = 2
    rot = np.tile([0.0, 0.0, 0.0, 1.0], (frames, 2, 1))
    rot[1, 1] = Rotation.from_rotvec([0.0, 0.0, np.pi / 2]).as_quat()
    anim = JointAnimation(["s0", "s1"], 30.0, rot, np.broadcast_to(kinematics.rest_local_matrices(source)[:, :3, 3], (frames, 2, 3)).copy())
    clip = MotionClip(source, anim, rest_is_standing=True, source_format="test", shares_bind_pose=True)
    plain, hung = retarget(clip, body), retarget(clip, rooted)
    assert rooted.names[0] not in hung.mapping
    world = _world(rooted, hung.animation)[:, :, :3, 3]
    np.testing.assert_allclose(world[:, 0], 0.0, atol=1e-12)
    np.testing.assert_allclose(world[:, 1:], _world(body, plain.animation)[:, :, :3, 3], atol=1e-9)
