"""glTF clip sampling: dev assets (fox) and the sampler interpolation modes."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from simcore.errors import InvalidInput
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import read_rigged_asset
from simcore.motion.gltf_clips import clip_names, read_gltf_clip, sample_node_worlds
from simcore.motion.timing import sample_track, slerp
from simcore.skeleton import kinematics
from simcore.skinning.lbs import linear_blend


@pytest.fixture(scope="module")
def fox(dev_assets) -> GltfDocument:
    return GltfDocument.from_bytes((dev_assets / "fox.glb").read_bytes())


def test_fox_clips_listed_and_selected(fox):
    assert clip_names(fox) == ["Survey", "Walk", "Run"]
    assert read_gltf_clip(fox, "Run").animation.name == "Run"
    assert read_gltf_clip(fox, 1).animation.name == "Walk"
    with pytest.raises(InvalidInput) as err:
        read_gltf_clip(fox, "Dance")
    assert err.value.code == "unknown_clip" and err.value.field == "motion.clip" and "'Walk'" in str(err.value)


def test_fox_walk_matches_keyed_rotation(fox):
    clip = read_gltf_clip(fox, "Walk", fps=24.0)
    anim = fox.items("animations")[1]
    times = [fox.accessor(s["input"]).ravel() for s in anim["samplers"]]
    t0, t1 = min(t.min() for t in times), max(t.max() for t in times)
    assert clip.skeleton.num_joints == 24
    assert clip.animation.num_frames == int(np.floor((t1 - t0) * 24 + 1e-6)) + 1
    nodes = fox.items("nodes")
    checked = 0
    for ch in anim["channels"]:
        if ch["target"]["path"] != "rotation":
            continue
        name = nodes[ch["target"]["node"]]["name"]
        j = clip.skeleton.names.index(name)
        sampler = anim["samplers"][ch["sampler"]]
        keys, values = fox.accessor(sampler["input"]).ravel(), fox.accessor(sampler["output"])
        k = len(keys) // 2
        frame = (keys[k] - t0) * 24
        assert abs(frame - round(frame)) < 1e-3  # keys sit on the 24 fps grid
        got = clip.animation.rotations[int(round(frame)), j]
        assert abs(np.dot(got, values[k] / np.linalg.norm(values[k]))) == pytest.approx(1.0, abs=1e-5), name
        checked += 1
    assert checked >= 10


def test_fox_clip_reproduces_artist_skinning(fox):
    asset = read_rigged_asset(fox)
    clip = read_gltf_clip(fox, "Survey")
    world = kinematics.global_transforms(clip.skeleton, kinematics.compose(clip.animation.rotations, clip.animation.translations))
    ours = linear_blend(asset.vertices, asset.weights, kinematics.skinning_matrices(clip.skeleton, world)[::10])
    times = np.arange(clip.animation.num_frames)[::10] / clip.animation.fps
    first_key = min(fox.accessor(s["input"]).min() for s in fox.items("animations")[0]["samplers"])
    artist_world = sample_node_worlds(fox, 0, times + first_key, asset.joint_nodes)
    artist = linear_blend(asset.vertices, asset.weights, artist_world @ np.linalg.inv(asset.bind_matrices))
    assert np.abs(ours - artist).max() < 1e-4 * np.ptp(asset.vertices, axis=0).max()


def test_sampler_modes():
    keys = np.array([0.0, 1.0, 2.0])
    values = np.array([[0.0], [10.0], [30.0]])
    t = np.array([-1.0, 0.5, 1.0, 1.5, 3.0])
    assert np.allclose(sample_track(keys, values, t, "LINEAR")[:, 0], [0, 5, 10, 20, 30])
    assert np.allclose(sample_track(keys, values, t, "STEP")[:, 0], [0, 0, 10, 10, 30])
    # CUBICSPLINE with zero tangents: smoothstep between values; with slope tangents it is linear.
    zero = np.stack([np.zeros(3), values[:, 0], np.zeros(3)], axis=1).reshape(-1, 1)
    assert np.allclose(sample_track(keys, zero, np.array([0.5]), "CUBICSPLINE")[0, 0], 5.0)
    lin = np.array([[10.0], [0.0], [10.0], [10.0], [10.0], [10.0], [10.0], [20.0], [10.0]])
    assert np.allclose(sample_track(keys, lin, np.array([0.25, 1.5]), "CUBICSPLINE")[:, 0], [2.5, 15.0])
    with pytest.raises(InvalidInput):
        sample_track(keys, values[:2], t, "LINEAR")


def test_rotation_track_slerps():
    q0 = Rotation.identity().as_quat()
    q1 = Rotation.from_rotvec([0, np.pi / 2, 0]).as_quat()
    got = sample_track(np.array([0.0, 1.0]), np.stack([q0, -q1]), np.array([0.5]), rotation=True)[0]
    want = Rotation.from_rotvec([0, np.pi / 4, 0]).as_quat()
    assert abs(np.dot(got, want)) == pytest.approx(1.0)
    assert np.allclose(slerp(q0, q0, np.array(0.3)), q0)
