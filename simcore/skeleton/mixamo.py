"""The Mixamo humanoid template: joint names and order (UniRig's <part:body> and <part:hand> blocks)."""

from __future__ import annotations

PREFIX = "mixamorig:"

BODY_JOINTS: tuple[str, ...] = (
    "Hips", "Spine", "Spine1", "Spine2", "Neck", "Head",
    "LeftShoulder", "LeftArm", "LeftForeArm", "LeftHand",
    "RightShoulder", "RightArm", "RightForeArm", "RightHand",
    "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase",
    "RightUpLeg", "RightLeg", "RightFoot", "RightToeBase",
)
# Parent of each body joint by name (Hips is the root).
BODY_PARENTS: dict[str, str | None] = {
    "Hips": None, "Spine": "Hips", "Spine1": "Spine", "Spine2": "Spine1", "Neck": "Spine2", "Head": "Neck",
    "LeftShoulder": "Spine2", "LeftArm": "LeftShoulder", "LeftForeArm": "LeftArm", "LeftHand": "LeftForeArm",
    "RightShoulder": "Spine2", "RightArm": "RightShoulder", "RightForeArm": "RightArm", "RightHand": "RightForeArm",
    "LeftUpLeg": "Hips", "LeftLeg": "LeftUpLeg", "LeftFoot": "LeftLeg", "LeftToeBase": "LeftFoot",
    "RightUpLeg": "Hips", "RightLeg": "RightUpLeg", "RightFoot": "RightLeg", "RightToeBase": "RightFoot",
}
FINGERS: tuple[str, ...] = ("Thumb", "Index", "Middle", "Ring", "Pinky")
# A cartoon four-fingered hand (a thumb and three fingers): the outer finger takes the pinky's slot, as
# Quaternius's characters name it (GDQuest's mannequin calls it ring), so only the Ring slots stay empty.
FOUR_FINGERS: tuple[str, ...] = ("Thumb", "Index", "Middle", "Pinky")
# 30 finger joints: per side, per finger, phalanges 1..3; each chain hangs off that side's Hand.
HAND_JOINTS: tuple[str, ...] = tuple(
    f"{side}Hand{finger}{k}" for side in ("Left", "Right") for finger in FINGERS for k in (1, 2, 3)
)
HAND_PARENTS: dict[str, str] = {
    f"{side}Hand{finger}{k}": (f"{side}Hand" if k == 1 else f"{side}Hand{finger}{k - 1}")
    for side in ("Left", "Right") for finger in FINGERS for k in (1, 2, 3)
}


def full_name(name: str) -> str:
    """`Hips` → `mixamorig:Hips`."""
    return name if name.startswith(PREFIX) else PREFIX + name


def bare_name(name: str) -> str:
    """`mixamorig:Hips` (or `mixamorig_Hips`, `mixamorig1:Hips`) → `Hips`."""
    for sep in (":", "_"):
        head, found, tail = name.partition(sep)
        if found and head.lower().startswith("mixamorig"):
            return tail
    return name
