"""Humanoid bone-map tables: Mixamo template slots → the joint names of each naming preset.

Presets: `mixamo` (`mixamorig:LeftForeArm`), `unreal` (the UE mannequin: `lowerarm_l`, `spine_01`, `thumb_01_l`),
`unity` (Unity's HumanBodyBones: `LeftLowerArm`, `UpperChest`, `LeftThumbProximal`) and `generic`
(`forearm_L`, `spine_01`, `thumb_L_01`). Slots are Mixamo's bare names (`LeftForeArm`, `RightHandIndex2`,
`HeadTop_End`, `LeftToe_End`); the torso and neck are chains ("spine", "neck") named by their order.
"""

from __future__ import annotations

from typing import Literal

from simcore.skeleton.mixamo import FINGERS, full_name

Preset = Literal["mixamo", "unreal", "unity", "generic"]
PRESETS: tuple[Preset, ...] = ("mixamo", "unreal", "unity", "generic")

# Side-less limb slot → (unreal, unity, generic) stem; unreal appends _l/_r, unity prefixes Left/Right,
# generic appends _L/_R.
LIMB_NAMES: dict[str, tuple[str, str, str]] = {
    "Shoulder": ("clavicle", "Shoulder", "shoulder"),
    "Arm": ("upperarm", "UpperArm", "upper_arm"),
    "ForeArm": ("lowerarm", "LowerArm", "forearm"),
    "Hand": ("hand", "Hand", "hand"),
    "UpLeg": ("thigh", "UpperLeg", "thigh"),
    "Leg": ("calf", "LowerLeg", "shin"),
    "Foot": ("foot", "Foot", "foot"),
    "ToeBase": ("ball", "Toes", "toe"),
    "Toe_End": ("ball_end", "Toes_End", "toe_end"),
}
CENTRE_NAMES: dict[str, tuple[str, str, str]] = {
    "Hips": ("pelvis", "Hips", "hips"),
    "Head": ("head", "Head", "head"),
    "HeadTop_End": ("head_end", "HeadTop_End", "head_end"),
}
UNITY_FINGERS = {"Thumb": "Thumb", "Index": "Index", "Middle": "Middle", "Ring": "Ring", "Pinky": "Little"}
UNITY_PHALANGES = ("Proximal", "Intermediate", "Distal", "Distal_End")
UNITY_SPINE = ("Spine", "Chest", "UpperChest")
_COLUMN = {"unreal": 0, "unity": 1, "generic": 2}


def _sided(stem: str, side: str, preset: str) -> str:
    left = side == "Left"
    if preset == "unreal":
        return f"{stem}_{'l' if left else 'r'}"
    if preset == "unity":
        return f"{side}{stem}"
    return f"{stem}_{'L' if left else 'R'}"


def _finger_name(side: str, finger: str, k: int, preset: str) -> str:
    if preset == "unreal":
        return f"{finger.lower()}_{k:02d}_{'l' if side == 'Left' else 'r'}"
    if preset == "unity":
        return f"{side}{UNITY_FINGERS[finger]}{UNITY_PHALANGES[min(k, 4) - 1]}"
    return f"{finger.lower()}_{'L' if side == 'Left' else 'R'}_{k:02d}"


def slot_name(slot: str, preset: Preset) -> str | None:
    """The preset's name for a Mixamo slot (`LeftForeArm`, `RightHandThumb2`, `Hips`); None for chain slots
    and names that are not slots."""
    if preset == "mixamo":
        return full_name(slot)
    if slot in CENTRE_NAMES:
        return CENTRE_NAMES[slot][_COLUMN[preset]]
    for side in ("Left", "Right"):
        if not slot.startswith(side):
            continue
        rest = slot[len(side):]
        if rest in LIMB_NAMES:
            return _sided(LIMB_NAMES[rest][_COLUMN[preset]], side, preset)
        for finger in FINGERS:
            stem = f"Hand{finger}"
            if rest.startswith(stem) and rest[len(stem):].isdigit():
                return _finger_name(side, finger, int(rest[len(stem):]), preset)
    return None


def chain_names(chain: str, count: int, preset: Preset) -> list[str]:
    """Names of a `spine` (hips to chest) or `neck` (chest to head) chain of `count` joints, root-ward first."""
    if preset == "mixamo":
        stem = "Spine" if chain == "spine" else "Neck"
        return [full_name(stem if k == 0 else f"{stem}{k}") for k in range(count)]
    if preset == "unity":
        if chain == "spine":
            return [UNITY_SPINE[k] if k < 3 else f"UpperChest{k - 1}" for k in range(count)]
        return ["Neck" if k == 0 else f"Neck{k}" for k in range(count)]
    stem = "spine" if chain == "spine" else "neck"
    if preset == "generic" and chain == "neck" and count == 1:
        return ["neck"]
    return [f"{stem}_{k + 1:02d}" for k in range(count)]
