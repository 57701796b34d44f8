"""Non-finite numbers in an upload are refused with a code naming what is broken: keyframe times or values
(the clip), skin weights (not 'vertex coordinates'); the skin evaluation leaves a broken clip out (issue 25)."""

from __future__ import annotations

import numpy as np
import pytest

from simcore.errors import InvalidInput
from simcore.evaluation.skin_eval import clip_skin_matrices
from simcore.ingest import ingest
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import read_rigged_asset
from simcore.motion.gltf_clips import read_gltf_clip
from tests.simcore.io.studio_rig_fixtures import studio_rig, to_glb, with_accessor_values

ORDER = ["hips", "spine", "head", "sword"]


def _nan_at(index: int):
    def edit(values: np.ndarray) -> np.ndarray:
        values[index] = np.nan
        return values
    return edit


def _broken_clip(part: str) -> GltfDocument:
    doc = studio_rig(ORDER, animated=True)
    sampler = doc["animations"][0]["samplers"][0]
    return GltfDocument.from_bytes(to_glb(with_accessor_values(doc, sampler[part], _nan_at(1))))


@pytest.mark.parametrize("part", ["input", "output"], ids=["key-times", "key-values"])
def test_a_clip_with_nan_keys_is_refused_with_its_own_code(part):
    with pytest.raises(InvalidInput) as err:
        read_gltf_clip(_broken_clip(part))
    assert err.value.code == "non_finite_keyframes" and err.value.field == "motion"
    assert "'swing'" in str(err.value)


@pytest.mark.parametrize("part", ["input", "output"], ids=["key-times", "key-values"])
def test_skin_evaluation_leaves_a_broken_clip_out(part):
    doc = _broken_clip(part)
    assert clip_skin_matrices(doc, read_rigged_asset(doc)) is None  # the only clip: nothing left, no traceback


def test_nan_skin_weights_are_reported_as_weights():
    doc = studio_rig(ORDER)
    broken = to_glb(with_accessor_values(doc, doc["meshes"][0]["primitives"][0]["attributes"]["WEIGHTS_0"], _nan_at(5)))
    for read in (lambda: ingest(broken, "glb"), lambda: read_rigged_asset(GltfDocument.from_bytes(broken))):
        with pytest.raises(InvalidInput) as err:
            read()
        assert err.value.code == "non_finite_weights" and "weights" in str(err.value)
