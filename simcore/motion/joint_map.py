"""Joint-name semantics: map skeleton joint names of common conventions onto Mixamo template slots.

Handles Mixamo (`mixamorig:LeftArm`), CMU/cgspeed BVH (`LeftUpLeg`, `LHipJoint`, `LowerBack`), Daz/Poser
BVH (`lShldr`, `rThigh`, `abdomen`), Motionbuilder-style BVH (`LeftShoulder` = upper arm when a
`LeftCollar` exists, `LeftElbow`, `LeftKnee`), Unreal (`upperarm_l`, `calf_r`, `spine_01`), Unity
humanoid and VRM (`LeftUpperArm`, `J_Bip_L_UpperArm`, `upperChest`), Blender/Rigify-ish (`UpperArm.L`).
Torso and neck joints are not named one-to-one across conventions, so they get a chain slot ("spine",
"neck") and are matched by their order along the chain in `name_mapping`.
"""

from __future__ import annotations

import re

import numpy as np

from simcore.skeleton import mixamo
from simcore.skeleton.types import Skeleton

# Side-less word (after stripping side markers and separators) → Mixamo limb slot without side.
LIMB_SYNONYMS: dict[str, str] = {
    "shoulder": "Shoulder", "clavicle": "Shoulder", "collar": "Shoulder", "collarbone": "Shoulder",
    "arm": "Arm", "upperarm": "Arm", "uparm": "Arm", "shldr": "Arm", "humerus": "Arm",
    "forearm": "ForeArm", "lowerarm": "ForeArm", "elbow": "ForeArm", "lowarm": "ForeArm",
    "hand": "Hand", "wrist": "Hand",
    "upleg": "UpLeg", "upperleg": "UpLeg", "thigh": "UpLeg", "femur": "UpLeg",
    "leg": "Leg", "lowerleg": "Leg", "shin": "Leg", "calf": "Leg", "knee": "Leg", "lowleg": "Leg",
    "foot": "Foot", "ankle": "Foot",
    "toebase": "ToeBase", "toe": "ToeBase", "toes": "ToeBase", "ball": "ToeBase",
}
# Words that name the side-less body joints or chains.
CENTRE_SYNONYMS: dict[str, str] = {
    "hips": "Hips", "hip": "Hips", "pelvis": "Hips",
    "spine": "spine", "abdomen": "spine", "ab": "spine", "lowerback": "spine", "chest": "spine",
    "upperchest": "spine", "torso": "spine", "back": "spine", "waist": "spine", "abdomen2": "spine",
    "neck": "neck",
    "head": "Head",
    "headtopend": "HeadTop_End", "headend": "HeadTop_End", "headtop": "HeadTop_End",
}
FINGER_SYNONYMS: dict[str, str] = {
    "thumb": "Thumb", "index": "Index", "middle": "Middle", "mid": "Middle", "ring": "Ring",
    "pinky": "Pinky", "pinkie": "Pinky", "little": "Pinky",
}
# Joints some conventions put between the pelvis and the thighs, or the spine and the clavicles:
# they have no Mixamo counterpart and must not steal the Hips / Shoulder slots.
SIDE_PELVIS_WORDS = ("hipjoint", "buttock", "pelvis")
NOISE_WORDS = {"mixamorig", "bip", "bip01", "bip001", "def", "j", "b", "c", "jnt", "bone", "mch", "org"}


def name_words(name: str) -> list[str]:
    """Lower-case words of a joint name: namespaces dropped, camelCase and separators split.

    `mixamorig:LeftUpLeg` → [left, up, leg]; `J_Bip_L_UpperArm` → [l, upper, arm]; `lShldr` → [l, shldr].
    """
    bare = mixamo.bare_name(name).rsplit(":", 1)[-1]
    spaced = re.sub(r"([a-z0-9])([A-Z])", r"\1 \2", bare)
    spaced = re.sub(r"([A-Z]+)([A-Z][a-z])", r"\1 \2", spaced)
    spaced = re.sub(r"([A-Za-z])(\d)", r"\1 \2", spaced)
    words = [w for w in re.split(r"[^A-Za-z0-9]+", spaced.lower()) if w]
    return [w for w in words if w not in NOISE_WORDS]


def _side(words: list[str]) -> tuple[str | None, list[str]]:
    """("Left" | "Right" | None, the words without the side marker)."""
    for k, w in enumerate(words):
        if w in ("left", "l", "lf", "lft"):
            return "Left", words[:k] + words[k + 1:]
        if w in ("right", "r", "rt", "rgt"):
            return "Right", words[:k] + words[k + 1:]
    return None, words


def joint_slot(name: str) -> str | None:
    """The Mixamo slot a joint name denotes (`LeftArm`, `RightHandIndex2`, `Hips`), a chain slot
    ("spine", "neck"), or None when the name is not recognised. Ambiguities that depend on the rest of
    the skeleton (a BVH `LeftShoulder` that is the upper arm) are settled in `skeleton_slots`."""
    all_words = name_words(name)
    if any(w in "".join(all_words) for w in SIDE_PELVIS_WORDS[:2]) or {"hip", "joint"} <= set(all_words):
        return None
    side, words = _side([w for w in all_words if w != "joint"])
    digits = [w for w in words if w.isdigit()]
    letters = [w for w in words if not w.isdigit()]
    key = "".join(letters)
    if not key:
        return None
    if side is None:
        if key in CENTRE_SYNONYMS:
            return CENTRE_SYNONYMS[key]
        if key.startswith("neck"):
            return "neck"
        if key.startswith("spine") or key.startswith("chest"):
            return "spine"
        return None
    if key in SIDE_PELVIS_WORDS:
        return None
    for word, finger in FINGER_SYNONYMS.items():
        if key in (word, "hand" + word, word + "finger", "finger" + word) or key == word + "s":
            n = int(digits[0]) if digits else 1
            return f"{side}Hand{finger}{min(max(n, 1), 4)}"
    if key in ("toeend", "toebaseend", "toesend"):
        return f"{side}Toe_End"
    if key == "hip":
        return f"{side}UpLeg"
    if key in LIMB_SYNONYMS:
        return side + LIMB_SYNONYMS[key]
    return None


def skeleton_slots(skeleton: Skeleton) -> list[str | None]:
    """Slot of every joint, with skeleton-wide fixes: a side `shoulder` below a `collar`/`clavicle` is the
    upper arm, `elbow`→forearm and `wrist`→hand shift likewise; duplicate limb slots are dropped."""
    slots = [joint_slot(n) for n in skeleton.names]
    keys = ["".join(w for w in _side(name_words(n))[1] if not w.isdigit() and w != "joint") for n in skeleton.names]
    for j, slot in enumerate(slots):
        if slot and slot.endswith("Shoulder") and keys[j] == "shoulder":
            p = skeleton.parents[j]
            while p >= 0:
                if keys[p] in ("collar", "clavicle", "collarbone"):
                    slots[j] = slot.replace("Shoulder", "Arm")
                    break
                p = skeleton.parents[p]
    counts: dict[str, int] = {}
    for s in slots:
        if s:
            counts[s] = counts.get(s, 0) + 1
    return [s if s and (counts[s] == 1 or s in ("spine", "neck")) else None for s in slots]


def _chain_members(skeleton: Skeleton, slots: list[str | None], slot: str) -> list[int]:
    """Joints with a chain slot, ordered root-ward first (by depth)."""
    members = [j for j, s in enumerate(slots) if s == slot]
    depth = np.zeros(skeleton.num_joints, np.int64)
    for j, p in enumerate(skeleton.parents):
        depth[j] = depth[p] + 1 if p >= 0 else 0
    return sorted(members, key=lambda j: depth[j])


def _map_chain(target: list[int], source: list[int]) -> dict[int, int]:
    """Target chain joint → source chain joint by relative position (ends to ends, many-to-one allowed)."""
    if not target or not source:
        return {}
    if len(target) == 1:
        return {target[0]: source[0]}
    return {t: source[int(round(k * (len(source) - 1) / (len(target) - 1)))] for k, t in enumerate(target)}


def name_mapping(source: Skeleton, target: Skeleton) -> dict[int, int]:
    """Target joint index → source joint index through shared slots, then identical names for the rest."""
    s_slots, t_slots = skeleton_slots(source), skeleton_slots(target)
    by_slot = {s: j for j, s in enumerate(s_slots) if s and s not in ("spine", "neck")}
    out = {j: by_slot[s] for j, s in enumerate(t_slots) if s in by_slot}
    for chain in ("spine", "neck"):
        out.update(_map_chain(_chain_members(target, t_slots, chain), _chain_members(source, s_slots, chain)))
    used = set(out.values())
    by_name = {mixamo.bare_name(n).lower(): j for j, n in enumerate(source.names)}
    for j, n in enumerate(target.names):
        k = by_name.get(mixamo.bare_name(n).lower())
        if j not in out and k is not None and k not in used and t_slots[j] is None and s_slots[k] is None:
            out[j] = k
    return out
