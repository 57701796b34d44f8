"""Naming presets: bone-map tables on every dev humanoid's own rig, descriptive names on generated creatures."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from simcore.motion.joint_map import _side, name_words
from simcore.skeleton.bone_maps import PRESETS, chain_names, slot_name
from simcore.skeleton.mixamo import BODY_JOINTS, HAND_JOINTS
from simcore.skeleton.naming import joint_names
from simcore.skeleton.types import Skeleton

CORE = {  # preset → names every humanoid must get (Mixamo slots Hips, Head, upper/lower arm and leg, both sides)
    "mixamo": ["mixamorig:Hips", "mixamorig:Head", "mixamorig:LeftArm", "mixamorig:RightForeArm",
               "mixamorig:LeftUpLeg", "mixamorig:RightLeg", "mixamorig:Spine"],
    "unreal": ["pelvis", "head", "upperarm_l", "lowerarm_r", "thigh_l", "calf_r", "spine_01"],
    "unity": ["Hips", "Head", "LeftUpperArm", "RightLowerArm", "LeftUpperLeg", "RightLowerLeg", "Spine"],
    "generic": ["hips", "head", "upper_arm_L", "forearm_R", "thigh_L", "shin_R", "spine_01"],
}
LEFT_MARKS = {"mixamo": "Left", "unreal": "_l", "unity": "Left", "generic": "_L"}


def _dev_humanoids(dev_assets) -> list[str]:
    with open(dev_assets / "MANIFEST.tsv", newline="") as f:
        return [row["file"] for row in csv.DictReader(f, delimiter="\t") if row["category"] == "humanoid"]


@pytest.fixture(scope="module")
def humanoid_rigs(dev_assets) -> dict[str, Skeleton]:
    from simcore.ingest import ingest

    def artist_skeleton(name: str) -> Skeleton:
        rig = ingest((dev_assets / name).read_bytes(), "glb").source_rig
        assert rig is not None, name
        return rig.skeleton

    files = _dev_humanoids(dev_assets)
    assert len(files) >= 8
    return {name: artist_skeleton(name) for name in files}


def _is_left(name: str, preset: str) -> bool:
    mark = LEFT_MARKS[preset]
    return name.split(":")[-1].startswith(mark) if mark == "Left" else name.endswith(mark) or f"{mark}_" in name


@pytest.mark.parametrize("preset", PRESETS)
def test_every_dev_humanoid_gets_the_presets_core_bones(humanoid_rigs, preset):
    for asset, skeleton in humanoid_rigs.items():
        naming = joint_names(skeleton, preset)
        assert naming.reading.startswith("humanoid"), asset
        assert len(set(naming.names)) == skeleton.num_joints, asset
        missing = set(CORE[preset]) - set(naming.names)
        assert not missing, (asset, missing)
        for old, new in zip(skeleton.names, naming.names):  # the rig's own side markers agree with ours
            side = _side(name_words(old))[0]
            if side and new in [slot_name(s, preset) for s in BODY_JOINTS]:
                assert _is_left(new, preset) == (side == "Left"), (asset, old, new)


def test_left_bones_are_on_the_characters_left(humanoid_rigs):
    for asset, skeleton in humanoid_rigs.items():
        names = joint_names(skeleton, "unreal").names
        pos = {n: skeleton.positions[j] for j, n in enumerate(names)}
        across = pos["upperarm_l"] - pos["upperarm_r"]
        legs = pos["thigh_l"] - pos["thigh_r"]
        assert np.dot(across, legs) > 0, asset  # both pairs agree on which side is left


def test_bone_map_tables_name_every_mixamo_slot_once():
    slots = [s for s in BODY_JOINTS + HAND_JOINTS if not s.startswith(("Spine", "Neck"))]
    slots += ["HeadTop_End", "LeftToe_End", "RightToe_End", "LeftHandIndex4", "RightHandThumb4"]
    for preset in PRESETS:
        names = [slot_name(s, preset) for s in slots]
        assert None not in names and len(set(names)) == len(names), preset
    assert slot_name("LeftForeArm", "unreal") == "lowerarm_l"
    assert slot_name("RightHandPinky2", "unity") == "RightLittleIntermediate"
    assert chain_names("spine", 3, "unity") == ["Spine", "Chest", "UpperChest"]
    assert chain_names("spine", 3, "unreal") == ["spine_01", "spine_02", "spine_03"]


def _chain(parent: int, points: list[list[float]], positions: list, parents: list) -> int:
    """Append a chain of joints under `parent`; returns its last joint."""
    for p in points:
        positions.append(p)
        parents.append(parent)
        parent = len(positions) - 1
    return parent


def _creature(wings: bool) -> Skeleton:
    """A quadruped facing +Z (left = +X): hips at z=0, spine forward, neck up to the head, four legs to the floor,
    a tail backwards; optionally a pair of long wings off the chest."""
    positions, parents = [[0.0, 1.0, 0.0]], [-1]
    chest = _chain(0, [[0, 1.0, 0.4], [0, 1.0, 0.8]], positions, parents)
    _chain(chest, [[0, 1.3, 1.0], [0, 1.5, 1.2]], positions, parents)
    _chain(0, [[0, 1.0, -0.3], [0, 0.95, -0.6], [0, 0.9, -0.9]], positions, parents)
    for x in (0.2, -0.2):
        _chain(chest, [[x, 0.9, 0.8], [x, 0.5, 0.8], [x, 0.05, 0.8]], positions, parents)
        _chain(0, [[x, 0.9, 0.0], [x, 0.5, 0.0], [x, 0.05, 0.0]], positions, parents)
        if wings:
            _chain(chest, [[x * 2, 1.2, 0.8], [x * 5, 1.3, 0.8], [x * 8, 1.3, 0.8]], positions, parents)
    names = ["root"] + [f"joint{k:03d}" for k in range(1, len(positions))]
    return Skeleton(np.asarray(positions), np.asarray(parents), names)


@pytest.mark.parametrize("preset", PRESETS)
def test_creatures_get_descriptive_names_from_their_structure(preset):
    skeleton = _creature(wings=True)
    naming = joint_names(skeleton, preset)
    assert naming.reading == "structure"
    by_name = {n: skeleton.positions[j] for j, n in enumerate(naming.names)}
    expected = {"hips", "spine_01", "spine_02", "neck", "head", "tail_01", "tail_03", "leg_front_L_01",
                "leg_front_R_03", "leg_back_L_02", "leg_back_R_01", "wing_L_01", "wing_R_03"}
    assert expected <= set(by_name), sorted(by_name)
    assert by_name["leg_front_L_01"][0] > 0 and by_name["wing_R_02"][0] < 0  # left is +X facing +Z
    assert by_name["leg_front_L_01"][2] > by_name["leg_back_L_01"][2]
    assert not any(n.startswith("joint") for n in naming.names)


def test_a_creature_turned_around_keeps_its_left():
    skeleton = _creature(wings=False)
    turned = Skeleton(skeleton.positions * [-1, 1, -1], skeleton.parents, skeleton.names)  # faces -Z
    names = joint_names(turned, "generic").names
    left = turned.positions[names.index("leg_front_L_01")]
    assert left[0] < 0  # facing -Z, the character's left is -X


def test_a_root_off_the_mid_plane_still_reads_the_body_plan():
    """A rig read off motion puts its root where the bones turn, not on the mid-plane: the plane is the one the
    joints mirror across best, not the one through the root."""
    skeleton = _creature(wings=False)
    positions = skeleton.positions.copy()
    positions[0, 0] = 0.12  # 5 % of the size off the mid-plane
    names = joint_names(Skeleton(positions, skeleton.parents, skeleton.names), "generic").names
    expected = {"hips", "spine_01", "spine_02", "neck", "head", "tail_01", "leg_front_L_01", "leg_front_R_01",
                "leg_back_L_01", "leg_back_R_01"}
    assert expected <= set(names), names
    assert positions[names.index("leg_front_L_01")][0] > 0
