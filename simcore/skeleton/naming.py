"""Joint naming presets (`options.naming`): engine conventions for humanoids, descriptive names for the rest.

A humanoid is recognised from its joint names (any convention simcore.motion.joint_map reads: Mixamo, Unreal,
Unity, BVH, Rigify-ish) or else from its structure (simcore.skeleton.body_plan read with each axis as up):
two legs reaching the floor, two arms off the spine, a head. Its joints are Mixamo slots, which the bone-map
tables (simcore.skeleton.bone_maps) name in the preset's convention; joints with no slot keep a name of their
own, or get a descriptive one when theirs is a placeholder (`joint12`, `extra01_02`). Any other skeleton gets
descriptive names from its body plan (spine_01, neck, head, tail_03, leg_front_L_02, wing_R_01) whatever the
preset.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

import numpy as np

from simcore.motion.joint_map import skeleton_slots
from simcore.skeleton.body_plan import BodyPlan, body_plan, unique_names
from simcore.skeleton.bone_maps import Preset, chain_names, slot_name
from simcore.skeleton.types import SHORT_BONE, Skeleton, tree_depths

HUMANOID_SLOTS = {"Hips", "Head", "LeftUpLeg", "RightUpLeg", "LeftLeg", "RightLeg", "LeftArm", "RightArm",
                  "LeftForeArm", "RightForeArm"}
LEG_SLOTS = ("UpLeg", "Leg", "Foot", "ToeBase", "Toe_End")
ARM_SLOTS = {2: ("Arm", "ForeArm"), 3: ("Arm", "ForeArm", "Hand"), 4: ("Shoulder", "Arm", "ForeArm", "Hand")}
PLACEHOLDER = re.compile(r"^(joint|bone|node|extra|root)[\d_]*(dup[\d_]*)?$", re.IGNORECASE)
UPRIGHT = 0.8  # a humanoid's head is above its hips: the root-to-head line's vertical share at least this
# Rotation taking each candidate up axis onto +Y (right-handed), for reading a rig modelled with another up.
UP_READINGS = {
    "y": np.eye(3),
    "z": np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]]), "-z": np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]),
    "x": np.array([[0.0, 1, 0], [-1, 0, 0], [0, 0, 1]]).T, "-x": np.array([[0.0, 1, 0], [-1, 0, 0], [0, 0, 1]]),
}


@dataclass
class Naming:
    """names: one per joint. reading: "humanoid (names)", "humanoid (structure, up y)" or "structure"."""

    names: list[str]
    reading: str


def _limb_joints(skeleton: Skeleton, path: list[int]) -> list[int]:
    """`path` without its near-zero-length joints (RigNet's duplicated joints): they take no limb slot."""
    size = max(float(np.ptp(skeleton.positions, axis=0).max()), 1e-9)
    pos, parents = skeleton.positions, skeleton.parents
    return [j for j in path if np.linalg.norm(pos[j] - pos[parents[j]]) > SHORT_BONE * size]


def _upright(skeleton: Skeleton, plan: BodyPlan) -> bool:
    """Whether the root-to-head line is mostly vertical (a biped stands; a dragon's neck reaches forward)."""
    if plan.head is None:
        return False
    d = skeleton.positions[plan.head] - skeleton.positions[0]
    return bool(d[1] > UPRIGHT * np.linalg.norm(d))


def _plan_slots(skeleton: Skeleton, plan: BodyPlan) -> list[str | None]:
    """Mixamo slots read from a body plan (legs, arms, spine, neck, head); None where it has none."""
    slots: list[str | None] = [None] * skeleton.num_joints
    if not _upright(skeleton, plan):
        return slots
    slots[0] = "Hips"
    for j in plan.spine:
        slots[j] = "spine"
    for j in plan.neck:
        slots[j] = "neck"
    if plan.head is not None:
        slots[plan.head] = "Head"
    head_chain = set(plan.neck) | ({plan.head} if plan.head is not None else set())
    for side, word in (("L", "Left"), ("R", "Right")):
        legs = [limb for limb in plan.limbs if limb.kind == "leg" and limb.side == side]
        arms = [limb for limb in plan.limbs if limb.kind in ("arm", "wing") and limb.side == side
                and limb.attach != 0 and limb.attach not in head_chain]
        if len(legs) == 1:
            for j, slot in zip(_limb_joints(skeleton, legs[0].path), LEG_SLOTS):
                slots[j] = word + slot
        if arms:
            joints = _limb_joints(skeleton, max(arms, key=lambda limb: len(limb.path)).path)
            for j, slot in zip(joints, ARM_SLOTS.get(min(len(joints), 4), ())):
                slots[j] = word + slot
    return slots


def _oriented(skeleton: Skeleton, rotation: np.ndarray) -> Skeleton:
    return Skeleton(skeleton.positions @ rotation.T, skeleton.parents, skeleton.names)


def humanoid_reading(skeleton: Skeleton) -> tuple[list[str | None], BodyPlan, str] | None:
    """(Mixamo slot per joint, body plan, how it was read) when `skeleton` is a humanoid, else None."""
    slots = skeleton_slots(skeleton)
    if HUMANOID_SLOTS <= set(slots):
        return slots, body_plan(skeleton), "humanoid (names)"
    for up, rotation in UP_READINGS.items():
        oriented = _oriented(skeleton, rotation)
        plan = body_plan(oriented)
        slots = _plan_slots(oriented, plan)
        if HUMANOID_SLOTS <= set(slots):
            return slots, plan, f"humanoid (structure, up {up})"
    return None


def joint_names(skeleton: Skeleton, preset: Preset) -> Naming:
    """Names of `skeleton`'s joints in the `preset` convention (see the module docstring)."""
    reading = humanoid_reading(skeleton)
    if reading is None:
        return Naming(body_plan(skeleton).names, "structure")
    slots, plan, how = reading
    names = [n if not PLACEHOLDER.match(n) else plan.names[j] for j, n in enumerate(skeleton.names)]
    depth = tree_depths(skeleton.parents)
    for chain in ("spine", "neck"):
        members = sorted((j for j, s in enumerate(slots) if s == chain), key=lambda j: depth[j])
        for j, name in zip(members, chain_names(chain, len(members), preset)):
            names[j] = name
    for j, slot in enumerate(slots):
        slot_label = slot_name(slot, preset) if slot and slot not in ("spine", "neck") else None
        if slot_label:
            names[j] = slot_label
    return Naming(unique_names(names), how)


def renamed(skeleton: Skeleton, names: list[str]) -> Skeleton:
    """A copy of `skeleton` with new joint names (everything else shared)."""
    return replace(skeleton, names=list(names))
