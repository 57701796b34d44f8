"""BVH reader: dev clips, rotation orders against scipy, malformed files, caps."""

from __future__ import annotations

import time

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from simcore.errors import InvalidInput, LimitExceeded
from simcore.io import bvh
from simcore.io.bvh import parse_bvh
from simcore.skeleton import kinematics
from tests.simcore.motion.motion_samples import SMALL_BVH as SMALL
from tests.simcore.motion.motion_samples import _depth_first, bvh_text, humanoid


@pytest.mark.parametrize("clip, joints, frames, fps", [
    ("mocap_cmu_01_01.bvh", 31, 2752, 120.0), ("mocap_pirouette.bvh", 43, 592, 120.0), ("mocap_boxing_toes.bvh", 21, 3069, 100.0),
])
def test_dev_clips_parse_fast(dev_assets, clip, joints, frames, fps):
    data = (dev_assets / clip).read_bytes()
    started = time.perf_counter()
    out = parse_bvh(data)
    elapsed = time.perf_counter() - started
    with_channels = sum(1 for n in out.skeleton.names if not n.endswith("_End"))
    assert with_channels == joints
    assert out.animation.rotations.shape == (frames, out.skeleton.num_joints, 4)
    assert out.animation.fps == pytest.approx(fps, rel=1e-3)
    assert np.allclose(np.linalg.norm(out.animation.rotations, axis=2), 1.0)
    assert 0.8 < np.ptp(out.skeleton.positions[:, 1]) < 2.2  # unit guess lands on a human height
    assert elapsed < 1.5


@pytest.mark.parametrize("order", ["ZXY", "XYZ", "YZX", "ZYX", "XZY", "YXZ"])
def test_rotation_orders_match_scipy_intrinsic(order):
    skel = humanoid()
    rng = np.random.default_rng(3)
    angles = rng.uniform(-80, 80, (4, skel.num_joints, 3))
    roots = rng.uniform(-1, 1, (4, 3))
    text = bvh_text(skel, roots, angles, [order] * skel.num_joints)
    clip = parse_bvh(text, unit_scale=0.01)
    names = clip.skeleton.names
    for j in _depth_first(skel):
        got = clip.animation.rotations[:, names.index(skel.names[j])]
        want = Rotation.from_euler(order, angles[:, j], degrees=True).as_quat()
        assert np.allclose(np.abs(np.sum(got * want, axis=1)), 1.0, atol=1e-9), (order, skel.names[j])
    assert np.allclose(clip.animation.translations[:, 0], roots, atol=1e-6)


def test_small_file_forward_kinematics():
    clip = parse_bvh(SMALL, unit_scale=0.01)
    assert clip.skeleton.names == ["Hips", "Spine", "Spine_End"]
    assert clip.animation.fps == pytest.approx(30.0, rel=1e-4)
    world = kinematics.global_transforms(clip.skeleton, kinematics.compose(clip.animation.rotations, clip.animation.translations))
    # Frame 1: Hips rotated by Z10·X20·Y30, Spine offset (0, 0.1, 0) rotated by it.
    r = Rotation.from_euler("ZXY", [10, 20, 30], degrees=True).as_matrix()
    assert np.allclose(world[1, 1, :3, 3], [0.01, 0.9, 0.0] + r @ [0, 0.1, 0])


def test_unit_guess_and_override():
    skel_cm = bvh_text(humanoid(), np.zeros((1, 3)), np.zeros((1, 22, 3)), ["ZXY"] * 22, unit=100.0)
    guessed = parse_bvh(skel_cm)
    assert guessed.unit == "cm" and guessed.unit_scale == 0.01
    assert np.ptp(guessed.skeleton.positions[:, 1]) == pytest.approx(1.63, abs=1e-6)  # toe 0.02 m → head end 1.65 m
    forced = parse_bvh(skel_cm, unit_scale=0.02)
    assert forced.unit == "option" and np.ptp(forced.skeleton.positions[:, 1]) == pytest.approx(3.26, abs=1e-6)
    skel_in = bvh_text(humanoid(), np.zeros((1, 3)), np.zeros((1, 22, 3)), ["ZXY"] * 22, unit=1 / 0.0254)
    assert parse_bvh(skel_in).unit == "in"


@pytest.mark.parametrize("mutate, line, words", [
    (lambda s: s.replace("OFFSET 0 10 0\n    CHANNELS", "OFFSET 0 ten 0\n    CHANNELS"), 8, "number"),
    (lambda s: s.replace("CHANNELS 3 Zrotation", "CHANNELS 3 Wrotation"), 9, "unknown channel"),
    (lambda s: s.replace("1 90 0 10 20 30 40 50 60", "1 90 0 10 20 30 40 50"), 20, "8 values"),
    (lambda s: s.replace("1 90 0 10 20 30 40 50 60", "1 90 0 10 abc 30 40 50 60"), 20, "'abc'"),
    (lambda s: s.replace("Frames: 2", "Frames: two"), 17, "Frames"),
    (lambda s: s.replace("Frames: 2", "Frames: 5"), None, "only 2 frame lines"),
    (lambda s: s.replace("  }\n}\nMOTION", "  }\nMOTION"), None, "end of hierarchy"),
    (lambda s: s.replace("MOTION\n", ""), None, "no MOTION"),
    (lambda s: s.replace("JOINT Spine", "BONE Spine"), 6, "expected JOINT"),
])
def test_malformed_files_name_the_line(mutate, line, words):
    with pytest.raises(InvalidInput) as err:
        parse_bvh(mutate(SMALL))
    assert err.value.code == "invalid_bvh" and err.value.field == "motion"
    assert words in str(err.value)
    if line is not None:
        assert f"line {line}:" in str(err.value)


def test_caps(monkeypatch):
    monkeypatch.setattr(bvh, "MAX_JOINTS", 2)
    with pytest.raises(LimitExceeded):
        parse_bvh(SMALL)
    monkeypatch.setattr(bvh, "MAX_JOINTS", 512)
    monkeypatch.setattr(bvh, "MAX_FRAMES", 1)
    with pytest.raises(LimitExceeded):
        parse_bvh(SMALL)
    monkeypatch.setattr(bvh, "MAX_BYTES", 100)
    with pytest.raises(LimitExceeded):
        parse_bvh(SMALL.encode())


def test_non_text_is_refused():
    with pytest.raises(InvalidInput, match="UTF-8"):
        parse_bvh(b"\xff\xfe\x00binary")
