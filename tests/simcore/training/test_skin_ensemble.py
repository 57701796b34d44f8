"""The family ensemble: members average their logits, a plain weights file reads as an ensemble of one, and
`rigforge train skin` with an "ensemble" section trains one member per family group into one file with its card."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pytest
import torch
from typer.testing import CliRunner

from cli.main import app
from simcore.model_weights import save_weights
from simcore.skinning.attention_model import ModelConfig, SkinAttention
from simcore.skinning.ensemble import SkinEnsemble
from simcore.skinning.learned import LearnedSkinning, learned_weights, load_model
from simcore.training.sample_cache import save_sample
from simcore.training.skin_dataset import DataConfig, build_skin_data
from simcore.training.skin_ensemble import save_ensemble
from simcore.training.skin_samples import make_sample
from simcore.training.skin_train import sample_tensors
from tests.simcore.training.creatures import capsule_dog
from tests.simcore.training.test_skin_family_cv import corpus

INPUTS = ("pair", "bone", "point", "candidates", "prior")


def _member(seed: int, width: int = 16) -> SkinAttention:
    """A small model with a trained-looking (non-zero) head, so members differ."""
    torch.manual_seed(seed)
    model = SkinAttention(ModelConfig(width=width, heads=2, bone_layers=1))
    for p in model.out.parameters():
        torch.nn.init.normal_(p, std=0.3)
    return model.eval()


def test_an_ensemble_averages_its_members_logits_and_survives_a_round_trip(tmp_path: Path) -> None:
    sample = sample_tensors(make_sample(capsule_dog(), np.random.default_rng(0), 200))
    args = [sample[k] for k in INPUTS]
    members = [_member(0), _member(1)]
    ensemble = SkinEnsemble(members).eval()
    with torch.no_grad():
        each = [m.logits(args[0], m.bones(args[1]), *args[2:]) for m in members]
        assert not torch.allclose(each[0], each[1])
        np.testing.assert_allclose(ensemble(*args).numpy(), torch.softmax((each[0] + each[1]) / 2, dim=-1).numpy(), atol=1e-6)
        path = tmp_path / "ensemble.safetensors"
        save_weights(ensemble, path, {})
        loaded = load_model(path)
        assert len(loaded.members) == 2 and not loaded.training
        np.testing.assert_allclose(loaded(*args).numpy(), ensemble(*args).numpy(), atol=1e-6)


def test_a_plain_weights_file_reads_as_an_ensemble_of_one(tmp_path: Path) -> None:
    dog = capsule_dog()
    path = tmp_path / "plain.safetensors"
    member = _member(2)
    save_weights(member, path, {})
    loaded = load_model(path)
    assert len(loaded.members) == 1 and not loaded.training
    sample = sample_tensors(make_sample(dog, np.random.default_rng(0), 200))
    with torch.no_grad():
        np.testing.assert_allclose(loaded(*[sample[k] for k in INPUTS]).numpy(), member(*[sample[k] for k in INPUTS]).numpy(),
                                   atol=1e-6)
    weights = learned_weights(dog.vertices, dog.faces, dog.skeleton, learned=LearnedSkinning(path))
    np.testing.assert_allclose(weights.sum(axis=1), 1.0, atol=1e-6)


def test_members_of_different_sizes_are_refused() -> None:
    with pytest.raises(ValueError, match="one network size"):
        SkinEnsemble([_member(0, 16), _member(0, 8)])


def test_train_skin_with_an_ensemble_section_trains_one_member_per_family_group(tmp_path: Path) -> None:
    root = corpus(tmp_path, [("a1", "train", "family=fa"), ("a2", "train", "family=fa"), ("b1", "train", "family=fb"),
                             ("c1", "train", "family=fc"), ("v1", "val", "family=fv")])
    data = DataConfig(corpus=str(root), variants=2, anny_bodies=0, vertices=200, val_vertices=200)
    cache = tmp_path / "cache"
    build_skin_data(data, cache, lambda name, done, total: None)
    out, log = tmp_path / "ensemble.safetensors", tmp_path / "logs" / "skin.jsonl"
    config = tmp_path / "config.json"
    config.write_text(json.dumps({
        "cache": str(cache), "out": str(out), "log": str(log), "data": asdict(data), "ensemble": {"folds": 2, "fold_steps": 2, "workers": 1},
        "train": {"steps": 3, "batch": 2, "points": 64, "val_every": 3, "log_every": 1,
                  "model": {"width": 8, "heads": 2, "bone_layers": 1}}}))
    result = CliRunner().invoke(app, ["train", "skin", "--config", str(config)])
    assert result.exit_code == 0, result.output
    assert "3 members" in result.output
    model = load_model(out)
    assert len(model.members) == 3
    events = [json.loads(line) for line in log.read_text().splitlines()]
    assert [e["event"] for e in events] == ["member", "member", "member", "end"]
    members = events[:3]
    held = [e["held_out"] for e in members]
    assert [] in held and sorted(sum(held, [])) == ["a1", "a2", "b1", "c1"] and ["a1", "a2"] in held
    for e in members:  # the whole-corpus member for the train steps, the family groups' for fold_steps
        assert e["steps"] == (3 if e["held_out"] == [] else 2)
        assert e["train_samples"] == 2 * (4 - len(e["held_out"]))  # two variants per character, its group left out
        assert (log.parent / "skin_members" / e["file"]).with_suffix(".jsonl").is_file()
    assert [e["val"]["l1"] for e in members] == sorted(e["val"]["l1"] for e in members)  # best first
    assert events[-1]["train_samples"] == 8 and events[-1]["val_samples"] == 1  # the whole-corpus member's data
    assert sum(events[-1]["categories"].values()) == 8
    card = out.with_suffix(".md").read_text()
    assert "3 members" in card and ": every family" in card and "member 2 alone" in card and "(the ensemble)" in card


def test_a_character_is_read_by_as_many_members_and_turns_as_the_pass_budget_allows(tmp_path: Path,
                                                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    from simcore.skinning import learned
    from simcore.skinning.pair_features import skin_inputs

    dog = capsule_dog()
    pairs = skin_inputs(dog.vertices, dog.faces, dog.skeleton).candidates.size
    both, first = tmp_path / "both.safetensors", tmp_path / "first.safetensors"
    save_weights(SkinEnsemble([_member(0), _member(1)]), both, {})
    save_weights(_member(0), first, {})

    def weights(path: Path, budget: int) -> np.ndarray:
        monkeypatch.setattr(learned, "PASS_PAIRS", budget)
        return learned_weights(dog.vertices, dog.faces, dog.skeleton, learned=LearnedSkinning(path, prior_share=0.0))

    one = weights(first, pairs)  # one member, one reading
    np.testing.assert_allclose(weights(both, pairs), one, atol=1e-9)
    two = weights(both, 2 * pairs)  # both members, one reading
    assert np.abs(two - one).max() > 1e-3
    monkeypatch.setattr(learned, "TURNS", (0.0,))
    np.testing.assert_allclose(weights(both, 10**9), two, atol=1e-9)
    monkeypatch.setattr(learned, "TURNS", (0.0, np.pi))
    assert np.abs(weights(both, 4 * pairs) - two).max() > 1e-3  # both members, both readings


def test_the_members_are_stored_best_first_by_their_own_val_score(tmp_path: Path) -> None:
    """A character too large for every member is read by the first ones, so the file must hold the best first."""
    rng = np.random.default_rng(0)
    cache, folder = tmp_path / "cache", tmp_path / "members"
    for split in ("train", "val"):
        save_sample(cache / split / f"dog_{split}.npz", make_sample(capsule_dog(), rng, 100).arrays())
    facts = []
    for k, l1 in enumerate((0.7, 0.5, 0.6)):
        folder.mkdir(exist_ok=True)
        save_weights(_member(k), folder / f"member_{k}.safetensors", {})
        facts.append({"file": f"member_{k}.safetensors", "held_out": [], "steps": 1, "best_step": 0,
                      "val": {"l1": l1, "deform": 0.0}, "val_at_start": {"l1": 0.9, "deform": 0.0}})
    out, log = tmp_path / "ensemble.safetensors", tmp_path / "log.jsonl"
    summary = save_ensemble(facts, folder, cache, out, log, {"train_samples": 3})
    assert [m["file"] for m in summary["members"]] == ["member_1.safetensors", "member_2.safetensors", "member_0.safetensors"]
    assert summary["train_samples"] == 3 and summary["val_samples"] == 1
    stored = load_model(out).networks()
    for network, k in zip(stored, (1, 2, 0)):
        torch.testing.assert_close(network.out[0].weight, _member(k).out[0].weight)
    assert [json.loads(line).get("file") for line in log.read_text().splitlines()][:3] == [m["file"] for m in summary["members"]]
