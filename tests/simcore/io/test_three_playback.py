"""three.js plays our animated and refined GLBs as we computed them (skinning + morph targets).

Needs `three` in the repository's node_modules (the dashboard's dependency); skipped until it is installed.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

from simcore.io.glb_rig_writer import write_rigged_glb
from simcore.io.gltf_validate import node_binary
from simcore.io.joint_tracks import joint_tracks
from simcore.skinning.lbs import linear_blend
from tests.simcore.io.rig_export_fixtures import bend_animation, capsule_glb, chain_skeleton, falloff_weights

SCRIPT = Path(__file__).with_name("three_playback.mjs")
REPO = Path(__file__).resolve().parents[3]

pytestmark = pytest.mark.skipif(not (REPO / "node_modules" / "three").is_dir(), reason="npm package three not installed")


def _play(path: Path, times: list[float]) -> dict:
    done = subprocess.run([node_binary(), str(SCRIPT), str(path), *map(str, times)], capture_output=True, text=True,
                          timeout=120, check=True)
    return json.loads(done.stdout)


@pytest.mark.parametrize("refined", [False, True])
def test_three_replays_skinned_and_morphed_frames(tmp_path, refined):
    glb, mesh = capsule_glb(textured=False)  # three's texture loaders need a browser
    skeleton = chain_skeleton(4)
    weights, animation = falloff_weights(mesh.vertices, skeleton, keep=3), bend_animation(skeleton)
    expected = linear_blend(mesh.vertices, weights, joint_tracks(skeleton, animation).skin_matrices(skeleton))
    extra = {}
    if refined:
        expected = expected + 0.01 * np.sin(np.arange(12)[:, None, None] + mesh.vertices[None, :, 1:2] * 20)
        extra["morph_frames"] = expected
    path = tmp_path / "clip.glb"
    stats = write_rigged_glb(glb, skeleton, weights, animation=animation, out_path=path, **extra).stats
    frames = [0, 5, 10]
    out = _play(path, [k / animation.fps + 1e-6 for k in frames])  # just after each key: STEP holds that frame
    # refined: quantized basis shapes and sparse quantized residuals (KHR_mesh_quantization), within their bound
    targets = stats["morph"]["targets"] if refined else 0
    assert out["skinned"] and out["bones"] == 4 and out["morphTargets"] == targets
    assert not refined or (stats["morph"]["basis_shapes"] > 0 and stats["morph"]["residual_targets"] > 0)
    bound = stats["morph"]["max_error"] if refined else 0.0
    for shown, k in zip(out["frames"], frames):
        np.testing.assert_allclose(shown, expected[k][:5], atol=bound + 1e-5)
