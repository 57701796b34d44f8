"""The learned skeleton model learns a generated creature, always decodes to a valid tree, and refuses bad weights."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import torch

from simcore.geometry.capsule_creatures import quadruped
from simcore.model_weights import ModelUnavailable, save_weights
from simcore.skeleton.grammar import SkeletonGrammar
from simcore.skeleton.learned import learned_skeleton, load_skeleton_model
from simcore.skeleton.learned_model import SkeletonModelConfig, SkeletonTokenModel, sequence_slots
from simcore.skeleton.predict import predict_skeleton
from simcore.skeleton.token_decoding import decode_tokens
from simcore.skeleton.tokenizer import Normalization, SkeletonTokenizer
from simcore.training.sample_cache import save_sample
from simcore.training.skeleton_dataset import make_skeleton_sample, upright_turned
from simcore.training.skeleton_train import LoadedSample, SkeletonTrainConfig, full_scale, squashed, train_skeleton
from simcore.training.skin_samples import normalised, variants
from tests.simcore.training.creatures import capsule_dog

TINY = SkeletonModelConfig(width=32, heads=2, encoder_layers=1, decoder_layers=2, queries=32, max_tokens=128, frequencies=4)




def test_tiny_model_lowers_its_loss_and_ships_a_loadable_file(tmp_path: Path) -> None:
    creature = capsule_dog()
    rng = np.random.default_rng(0)
    tokenizer = SkeletonTokenizer(max_length=TINY.max_tokens)
    for k, c in enumerate(variants(creature, rng, 3, 20.0, turn=False)):
        save_sample(tmp_path / "data" / "train" / f"dog_{k}.npz",
                    make_skeleton_sample(upright_turned(c, rng, 20.0), rng, 512, tokenizer).arrays())
    save_sample(tmp_path / "data" / "val" / "dog.npz", make_skeleton_sample(normalised(creature), rng, 512, tokenizer).arrays())
    config = SkeletonTrainConfig(steps=60, batch=3, points=256, lr=3e-3, val_every=30, decode_every=60, decode_val=1,
                                 log_every=10, threads=1, axis_scale=0.1, model=replace(TINY, dropout=0.1))
    out = tmp_path / "skeleton.safetensors"
    summary = train_skeleton(config, tmp_path / "data", out, tmp_path / "log.jsonl", lambda step, total, entry: None)
    assert summary["val"]["nll"] < summary["val_at_start"]["nll"] - 1.0
    assert len((tmp_path / "log.jsonl").read_text().splitlines()) >= 6
    skeleton, report = learned_skeleton(creature.vertices, creature.faces, candidates=4, model_path=out)
    assert skeleton.validate().num_joints == report["joints"] and len(report["candidates"]) == 4
    assert summary["classes"] == {"articulation": 3}
    assert {c["class"] for c in report["candidates"]} == {"articulation"}  # only the classes it was trained on


@pytest.mark.parametrize(("classes", "decoded"), [(None, {"articulation", "mixamo", "vroid"}),
                                                 ({"articulation": 5, "none": 2}, {"articulation", "none"})])
def test_a_file_decodes_the_classes_it_was_trained_on(tmp_path: Path, classes: dict | None, decoded: set[str]) -> None:
    """A summary without `classes` (files trained before creatures) decodes the first three classes."""
    torch.manual_seed(0)
    path = tmp_path / "skeleton.safetensors"
    summary = {"config": {"points": 256}, **({"classes": classes} if classes else {})}
    save_weights(SkeletonTokenModel(TINY).eval(), path, summary)
    vertices, faces, _ = quadruped(count=6)
    _, report = learned_skeleton(vertices, faces, candidates=4, model_path=path)
    assert {c["class"] for c in report["candidates"]} == decoded


def test_untrained_model_decodes_valid_trees_within_the_caps() -> None:
    torch.manual_seed(0)
    model = SkeletonTokenModel(TINY).eval()
    grammar = SkeletonGrammar(max_length=TINY.max_tokens, max_joints=30)
    points = torch.rand(200, 6) * 2 - 1
    tokenizer = SkeletonTokenizer(max_length=TINY.max_tokens)
    decoded = decode_tokens(model, points, ["articulation", "mixamo", "vroid", "none"], grammar,
                            temperature=1.5, generator=torch.Generator().manual_seed(1))
    for tokens, log_prob in decoded:
        assert grammar.run(tokens).complete and len(tokens) <= TINY.max_tokens and np.isfinite(log_prob)
        skeleton = tokenizer.decode(tokens, Normalization(np.zeros(3), 1.0))
        assert 1 <= skeleton.validate().num_joints <= 30


def test_slots_name_each_next_coordinate() -> None:
    vertices, faces, skeleton = quadruped(count=6)
    tokens = SkeletonTokenizer().encode(skeleton, Normalization.from_points(vertices))
    slots = sequence_slots(tokens, SkeletonGrammar())
    assert slots[1] == 0 and list(slots[2:4]) == [1, 2]  # after <cls> x comes y, then z
    assert set(slots.tolist()) <= {0, 1, 2, 3, 4, 5, 6}  # no template joints in a dog


def test_a_squashed_sample_moves_points_and_joints_alike() -> None:
    vertices, faces, skeleton = quadruped(count=6)
    tokenizer, unit = SkeletonTokenizer(), Normalization(np.zeros(3), 1.0)
    tokens = tokenizer.encode(skeleton, Normalization.from_points(vertices))
    rng = np.random.default_rng(0)
    normals = rng.normal(size=(50, 3))
    cloud = np.hstack([rng.uniform(-1, 1, (50, 3)), normals / np.linalg.norm(normals, axis=1, keepdims=True)])
    sample = LoadedSample(torch.from_numpy(cloud.astype(np.float32)), torch.from_numpy(tokens),
                          torch.from_numpy(sequence_slots(tokens, SkeletonGrammar())), np.zeros((1, 3)), "quadruped")
    factors = np.array([0.5, 0.8, 1.0])
    points, squashed_tokens = squashed(sample, factors)
    np.testing.assert_allclose(points[:, :3].numpy(), cloud[:, :3] * factors, atol=1e-6)
    np.testing.assert_allclose(points[:, 3:].norm(dim=1).numpy(), 1.0, atol=1e-5)
    assert np.all(np.sum(points[:, 3:].numpy() * cloud[:, 3:] / factors, axis=1) > 0)  # normals stay on their side
    before = tokenizer.model_frame(tokenizer.decode(tokens, unit).positions)
    after = tokenizer.model_frame(tokenizer.decode(squashed_tokens.numpy(), unit).positions)
    np.testing.assert_allclose(after, before * factors, atol=2.0 / 256)  # within one coordinate bin
    np.testing.assert_array_equal(squashed_tokens[tokens >= 256].numpy(), tokens[tokens >= 256])  # specials kept
    unchanged = squashed(sample, np.ones(3))[1].numpy()
    np.testing.assert_array_equal(unchanged, tokens)


@pytest.mark.parametrize("content", [None, b"not a safetensors file"])
def test_missing_or_corrupt_weights_raise_a_clear_error(tmp_path: Path, content: bytes | None) -> None:
    path = tmp_path / "skeleton.safetensors"
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(ModelUnavailable) as err:
        load_skeleton_model(path)
    assert err.value.code == "model_unavailable" and err.value.field == "skeleton" and str(path) in str(err.value)


def test_learned_method_without_weights_is_a_clear_error(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import simcore.skeleton.learned as learned

    monkeypatch.setattr(learned, "WEIGHTS", tmp_path / "absent.safetensors")
    vertices, faces, _ = quadruped(count=6)
    with pytest.raises(ModelUnavailable):
        predict_skeleton(vertices, faces, method="learned")


def test_stacked_joints_merge_into_their_parent_and_keep_their_children() -> None:
    from simcore.skeleton.learned import without_stacked
    from simcore.skeleton.types import Skeleton

    chain = Skeleton(np.array([[0, 0, 0], [0, 1, 0], [0, 1, 0], [0, 2, 0], [1, 1, 0.0]]), np.array([-1, 0, 1, 2, 2]),
                     ["root", "a", "a_twin", "tip", "side"])
    merged = without_stacked(chain, 0.01)
    assert merged.names == ["root", "a", "tip", "side"]
    assert merged.parents.tolist() == [-1, 0, 1, 1]


def test_full_scale_keeps_the_longest_extent_of_a_squashed_sample() -> None:
    cloud = torch.from_numpy(np.random.default_rng(1).uniform(-1, 1, (200, 6)) * [1.0, 0.5, 0.25, 1, 1, 1])
    extents = np.ptp(cloud[:, :3].numpy(), axis=0)
    factors = full_scale(np.array([0.6, 0.9, 1.0]), cloud)  # x, the longest side, squashed most
    np.testing.assert_allclose((extents * factors).max(), extents.max())
    np.testing.assert_allclose(factors / factors[0], [1.0, 1.5, 1 / 0.6])  # the shape's proportions still change
    np.testing.assert_allclose(full_scale(np.array([1.0, 0.7, 0.8]), cloud), [1.0, 0.7, 0.8])  # longest kept
