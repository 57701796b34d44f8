"""The learned skinning model trains on a generated creature, predicts rows summing to 1, and refuses bad weight files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from simcore.model_weights import ModelUnavailable
from simcore.skinning.attention_model import ModelConfig
from simcore.skinning.learned import learned_weights, load_model
from simcore.training.sample_cache import save_sample
from simcore.training.skin_samples import make_sample, variants
from simcore.training.skin_train import TrainConfig, train_skin
from tests.simcore.training.creatures import capsule_dog


def test_tiny_model_learns_and_predicts_normalised_rows(tmp_path: Path) -> None:
    creature = capsule_dog()
    rng = np.random.default_rng(0)
    for k, c in enumerate(variants(creature, rng, 3, 30.0)):
        save_sample(tmp_path / "data" / "train" / f"dog_{k}.npz", make_sample(c, rng, 600).arrays())
    save_sample(tmp_path / "data" / "val" / "dog.npz", make_sample(creature, rng, 600).arrays())
    config = TrainConfig(steps=40, batch=2, points=256, lr=5e-3, val_every=20, log_every=10, model=ModelConfig(width=16, heads=2, bone_layers=1))
    out = tmp_path / "model.safetensors"
    summary = train_skin(config, tmp_path / "data", out, tmp_path / "log.jsonl", lambda step, total, entry: None)
    assert summary["val"]["l1"] < summary["val_at_start"]["l1"] - 0.02  # better than the geodesic prior it starts from
    assert len((tmp_path / "log.jsonl").read_text().splitlines()) >= 4
    weights = learned_weights(creature.vertices, creature.faces, creature.skeleton, model_path=out)
    assert weights.shape == (len(creature.vertices), creature.skeleton.num_joints)
    np.testing.assert_allclose(weights.sum(axis=1), 1.0, atol=1e-6)
    assert np.all(weights >= 0)


@pytest.mark.parametrize("content", [None, b"not a safetensors file"])
def test_missing_or_corrupt_weights_raise_a_clear_error(tmp_path: Path, content: bytes | None) -> None:
    path = tmp_path / "skin.safetensors"
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(ModelUnavailable) as err:
        load_model(path)
    assert err.value.code == "model_unavailable" and str(path) in str(err.value)
