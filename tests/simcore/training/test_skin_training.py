"""The learned skinning model trains on a generated creature, predicts rows summing to 1, and refuses bad weight files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
import torch
from scipy.spatial import cKDTree

from simcore.model_weights import ModelUnavailable, save_weights
from simcore.skeleton.types import Skeleton
from simcore.skinning.attention_model import ModelConfig, SkinAttention
from simcore.skinning.learned import LearnedSkinning, learned_weights, load_model, with_armature_root
from simcore.training.sample_cache import save_sample
from simcore.training.skin_samples import Character, decimated, make_sample, normalised, rerooted, subdivided, variants
from simcore.training.skin_train import TrainConfig, batch_losses, sample_tensors, train_skin
from tests.simcore.training.creatures import capsule_dog


def _tiny_run(tmp_path: Path, ema: float) -> tuple[Character, Path, dict]:
    """A tiny model trained for 40 steps on the capsule dog: (the dog, the weights file, the training summary)."""
    creature = capsule_dog()
    rng = np.random.default_rng(0)
    for k, c in enumerate(variants(creature, rng, 3, 30.0)):
        save_sample(tmp_path / "data" / "train" / f"dog_{k}.npz", make_sample(c, rng, 600).arrays())
    save_sample(tmp_path / "data" / "val" / "dog.npz", make_sample(creature, rng, 600).arrays())
    config = TrainConfig(steps=40, batch=2, points=256, lr=5e-3, val_every=20, log_every=10, ema=ema,
                         model=ModelConfig(width=16, heads=2, bone_layers=1, dropout=0.1))
    out = tmp_path / "model.safetensors"
    return creature, out, train_skin(config, tmp_path / "data", out, tmp_path / "log.jsonl", lambda step, total, entry: None)


@pytest.mark.parametrize("ema", [0.0, 0.8])
def test_tiny_model_learns_and_predicts_normalised_rows(tmp_path: Path, ema: float) -> None:
    creature, out, summary = _tiny_run(tmp_path, ema)
    assert summary["val"]["l1"] < summary["val_at_start"]["l1"] - 0.02  # better than the geodesic prior it starts from
    assert len((tmp_path / "log.jsonl").read_text().splitlines()) >= 4
    weights = learned_weights(creature.vertices, creature.faces, creature.skeleton, learned=LearnedSkinning(out))
    assert weights.shape == (len(creature.vertices), creature.skeleton.num_joints)
    np.testing.assert_allclose(weights.sum(axis=1), 1.0, atol=1e-6)
    assert np.all(weights >= 0)


def test_ema_scores_and_saves_the_average_not_the_last_weights(tmp_path: Path) -> None:
    """An average that barely moves (decay near 1) stays at the model after the first step: the val score and the
    saved file are then those of that near-untrained model, although the raw weights learn (the test above)."""
    _, _, summary = _tiny_run(tmp_path, 0.99999)
    assert summary["val"]["l1"] > summary["val_at_start"]["l1"] - 0.01


@pytest.mark.parametrize("content", [None, b"not a safetensors file"])
def test_missing_or_corrupt_weights_raise_a_clear_error(tmp_path: Path, content: bytes | None) -> None:
    path = tmp_path / "skin.safetensors"
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(ModelUnavailable) as err:
        load_model(path)
    assert err.value.code == "model_unavailable" and str(path) in str(err.value)


def _under_armature_root(c: Character, depth: int) -> Character:
    """`c` hung from `depth` stacked unweighted roots below its own root (how many artist rigs look)."""
    for _ in range(depth):
        c = Character(c.name, c.category, c.vertices, c.faces, with_armature_root(c.vertices, c.skeleton),
                      sp.hstack([sp.csr_matrix((len(c.vertices), 1)), c.weights]).tocsr())
    return c


@pytest.mark.parametrize("depth", [1, 2])
def test_rerooted_takes_out_unweighted_armature_roots(depth: int) -> None:
    dog = normalised(capsule_dog())
    out = rerooted(normalised(_under_armature_root(capsule_dog(), depth)))
    assert out.skeleton.names == dog.skeleton.names
    np.testing.assert_array_equal(out.skeleton.parents, dog.skeleton.parents)
    np.testing.assert_allclose(out.weights.toarray(), dog.weights.toarray())


def test_rerooted_keeps_a_weighted_root() -> None:
    dog = normalised(capsule_dog())
    assert rerooted(dog) is dog


def test_a_decimated_variant_is_coarser_and_keeps_its_nearest_vertex_artist_rows() -> None:
    dog = subdivided(normalised(capsule_dog()))
    out = decimated(dog, np.random.default_rng(0))
    assert len(out.vertices) < 0.75 * len(dog.vertices) and out.faces.max() < len(out.vertices)
    nearest = cKDTree(dog.vertices).query(out.vertices)[1]
    np.testing.assert_allclose(out.weights.toarray(), dog.weights[nearest].toarray(), atol=1e-6)
    assert out.skeleton is dog.skeleton


def test_variants_are_decimated_only_when_asked() -> None:
    dog = subdivided(normalised(capsule_dog()))
    plain = variants(dog, np.random.default_rng(0), 4, 30.0)
    coarse = variants(dog, np.random.default_rng(0), 4, 30.0, decimate=1.0)
    assert [len(plain[k].vertices) for k in (0, 1, 3)] == [len(dog.vertices)] * 3
    assert len(coarse[1].vertices) < len(dog.vertices) and len(coarse[3].vertices) < len(dog.vertices)
    assert len(coarse[0].vertices) == len(dog.vertices) and len(coarse[2].vertices) > len(dog.vertices)


def test_batched_losses_are_the_mean_of_per_sample_losses() -> None:
    """Samples with different joint and candidate counts in one forward pass score as they do alone."""
    rng = np.random.default_rng(1)
    dog = capsule_dog()
    small = Character("small", "other", dog.vertices, dog.faces, *_merged_legs(dog))
    samples = [sample_tensors(make_sample(c, rng, 300)) for c in (dog, small)]
    assert samples[0]["candidates"].shape[1] != samples[1]["candidates"].shape[1]
    torch.manual_seed(0)
    model = SkinAttention(ModelConfig(width=16, heads=2, bone_layers=1))
    for p in model.out.parameters():  # a trained-looking head, not the zero start
        torch.nn.init.normal_(p, std=0.3)
    with torch.no_grad():
        both = batch_losses(model, samples)
        alone = [batch_losses(model, [s]) for s in samples]
    for key in ("l1", "ce", "deform"):
        assert float(both[key]) == pytest.approx(np.mean([float(a[key]) for a in alone]), rel=1e-5)


def _merged_legs(c: Character) -> tuple[Skeleton, sp.csr_matrix]:
    """The trunk joints only (every leg joint's weight moved to the trunk): fewer than 16 joints, so fewer candidates."""
    keep = np.flatnonzero([not n.startswith(("leg", "foot", "paw")) for n in c.skeleton.names])
    if len(keep) == c.skeleton.num_joints:
        keep = np.arange(max(2, c.skeleton.num_joints // 2))
    sub, kept = c.skeleton.without(~np.isin(np.arange(c.skeleton.num_joints), keep))
    dense = c.weights.toarray()
    merged = dense[:, kept].copy()
    merged[:, 0] += dense.sum(axis=1) - merged.sum(axis=1)
    return sub, sp.csr_matrix(merged)


def test_dropout_acts_in_training_only_and_is_stored_with_the_weights(tmp_path: Path) -> None:
    sample = sample_tensors(make_sample(capsule_dog(), np.random.default_rng(2), 200))
    torch.manual_seed(0)
    model = SkinAttention(ModelConfig(width=16, heads=2, bone_layers=1, dropout=0.3))
    for p in model.out.parameters():
        torch.nn.init.normal_(p, std=0.3)
    args = [sample[k] for k in ("pair", "bone", "point", "candidates", "prior")]
    with torch.no_grad():
        assert not torch.equal(model(*args), model(*args))  # training mode: dropout draws differ
        model.eval()
        np.testing.assert_array_equal(model(*args).numpy(), model(*args).numpy())
        path = tmp_path / "dropout.safetensors"
        save_weights(model, path, {})
        loaded = load_model(path)
        assert loaded.config.member.dropout == 0.3 and not loaded.training
        np.testing.assert_allclose(loaded(*args).numpy(), model(*args).numpy(), atol=1e-6)


def test_helper_samples_never_offer_a_weightless_joint_as_the_nearest_bone() -> None:
    """With `helpers`, a joint the artist left unweighted (a pole target at a foot) owns no bone in the sample's
    inputs, as in a job keeping the rig; without, it is the nearest joint of the vertices around it."""
    dog = capsule_dog()
    foot = int(np.argmin(dog.skeleton.positions[:, 1]))
    s = dog.skeleton
    pole = Skeleton(np.vstack([s.positions, s.positions[foot]]), np.append(s.parents, 0), [*s.names, "Pole"])
    weights = sp.hstack([dog.weights, sp.csr_matrix((len(dog.vertices), 1))]).tocsr()
    c = Character("dog", "quadruped", dog.vertices, dog.faces, pole, weights)
    plain = make_sample(c, np.random.default_rng(0), 10_000)
    helped = make_sample(c, np.random.default_rng(0), 10_000, helpers=True)
    index = pole.num_joints - 1
    assert (plain.inputs.candidates[:, 0] == index).any()
    assert not (helped.inputs.candidates[:, 0] == index).any() and np.all(np.isfinite(helped.inputs.pair))


@pytest.mark.parametrize("rigs", [(), ("mixamo", "mixamoo")])
def test_an_unknown_or_empty_anny_rig_list_fails_when_the_config_is_read(rigs: tuple[str, ...]) -> None:
    from simcore.errors import InvalidInput
    from simcore.training.skin_dataset import DataConfig

    with pytest.raises(InvalidInput, match="anny rigs must be some of mixamo, game_engine, cmu_mb") as caught:
        DataConfig(anny_rigs=rigs)
    assert caught.value.field == "data.anny_rigs"
    assert DataConfig(anny_rigs=("cmu_mb", "soma")).anny_rigs == ("cmu_mb", "soma")
