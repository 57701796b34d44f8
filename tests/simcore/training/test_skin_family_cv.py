"""Family cross-validation of the skinning recipe (`rigforge train skin-cv`): folds never split a source family,
each fold's model is trained without its held-out characters, and every train character is scored once, by a model
that never saw it, beside the geodesic method."""

from __future__ import annotations

import io
from pathlib import Path

import pytest
import torch
from rich.console import Console
from typer.testing import CliRunner

from cli.main import app
from cli.train_skin_cv import render
from simcore.errors import InvalidInput
from simcore.evaluation.assets import family_folds, read_families
from simcore.evaluation.skin_eval import evaluate_skinning
from simcore.model_weights import save_weights
from simcore.skinning.attention_model import ModelConfig, SkinAttention
from simcore.skinning.ensemble import SkinEnsemble
from simcore.skinning.learned import SHIPPED
from simcore.training.skin_dataset import DataConfig, build_skin_data
from simcore.training.skin_family_cv import family_cv, stored_members_cv
from simcore.training.skin_train import TrainConfig, load_samples
from tests.simcore.training.corpus_fixture import assert_each_held_out_once, corpus


def test_folds_keep_families_whole_and_balance_their_sizes(tmp_path: Path) -> None:
    root = corpus(tmp_path, [("a1", "train", "family=fa; x"), ("a2", "train", "family=fa"), ("a3", "train", "family=fa"),
                             ("b1", "train", "family=fb"), ("c1", "train", ""), ("d1", "train", "family=fd"),
                             ("v1", "val", "family=fv")])
    assert read_families(root)["c1"] == "c1" and read_families(root)["a2"] == "fa"
    folds = family_folds(root, "train", 2)
    assert sorted(sum(folds, [])) == ["a1", "a2", "a3", "b1", "c1", "d1"]
    assert ["a1", "a2", "a3"] in folds and sorted(map(len, folds)) == [3, 3]
    with pytest.raises(InvalidInput, match="4 families, fewer than 5 folds"):
        family_folds(root, "train", 5)


def test_every_train_character_is_scored_once_by_a_model_that_never_saw_it(tmp_path: Path) -> None:
    root = corpus(tmp_path, [("a1", "train", "family=fa"), ("a2", "train", "family=fa"), ("b1", "train", "family=fb"),
                             ("c1", "train", "family=fc"), ("v1", "val", "family=fv")])
    cache = tmp_path / "cache"
    build_skin_data(DataConfig(corpus=str(root), variants=2, anny_bodies=0, vertices=200, val_vertices=200), cache,
                    lambda name, done, total: None)
    assert len(load_samples(cache / "train", exclude={"a1", "a2"})[0]) == 4  # b1 and c1, two variants each
    config = TrainConfig(steps=3, batch=2, points=64, val_every=3, log_every=1,
                         model=ModelConfig(width=8, heads=2, bone_layers=1))
    reports: list[tuple[int, int]] = []
    result = family_cv(config, cache, root, 2, tmp_path / "cv", 1, lambda done, total: reports.append((done, total)))
    assert_each_held_out_once(result, "geodesic", ["a1", "a2", "b1", "c1"], 2, reports, 6)
    out = io.StringIO()
    render(result, Console(file=out, width=160))
    assert "of 4 held-out characters" in out.getvalue() and "ALL (humanoid)" in out.getvalue()


def _random_member(seed: int) -> SkinAttention:
    """A small skinning network whose every parameter is random (distinct members give distinct weights)."""
    torch.manual_seed(seed)
    member = SkinAttention(ModelConfig(width=8, heads=2, bone_layers=1))
    with torch.no_grad():
        for parameter in member.parameters():
            parameter.normal_(0.0, 0.5)
    return member.eval()


def test_stored_fold_members_score_the_families_they_never_saw(tmp_path: Path) -> None:
    """`skin-cv --members`: each fold member of an ensemble file, and no other, skins the characters the file says it
    was trained without (the rows equal `eval skin` with that member alone); a file without fold members is refused."""
    root = corpus(tmp_path, [("a1", "train", "family=fa"), ("b1", "train", "family=fb"), ("v1", "val", "family=fv")])
    whole, fold_a, fold_b = (_random_member(seed) for seed in (1, 2, 3))
    facts = [{"held_out": held, "best_step": 2, "val": {"l1": 0.5}, "train_samples": 2} for held in ([], ["a1"], ["b1"])]
    ensemble = tmp_path / "ensemble.safetensors"
    save_weights(SkinEnsemble([whole, fold_a, fold_b]), ensemble, {"members": facts})
    reports: list[tuple[int, int]] = []
    stored = stored_members_cv(ensemble, root, tmp_path / "stored", lambda done, total: reports.append((done, total)))
    swapped = tmp_path / "swapped.safetensors"  # the same folder scored again for another file: its own members count
    save_weights(SkinEnsemble([whole, fold_b, fold_a]), swapped, {"members": facts})
    again = {(r["name"], r["method"]): r["l1"] for r in
             stored_members_cv(swapped, root, tmp_path / "stored", lambda done, total: None)["assets"]}
    assert reports == [(1, 2), (2, 2)] and [f["held_out"] for f in stored["folds"]] == [["a1"], ["b1"]]
    got = {(r["name"], r["method"]): r["l1"] for r in stored["assets"]}
    expected = {}
    for name, member in (("a1", fold_a), ("b1", fold_b)):
        alone = tmp_path / f"alone_{name}.safetensors"
        save_weights(member, alone, {})
        rows = evaluate_skinning(root, ["learned"], split="train", names={name}, learned=SHIPPED.overridden(alone)).rows
        expected[(name, "learned")] = rows[0].metrics["l1"]
    assert {key: got[key] for key in expected} == pytest.approx(expected, abs=1e-6) and ("a1", "geodesic") in got
    assert again[("a1", "learned")] == pytest.approx(got[("b1", "learned")], abs=1e-6)  # a1 and b1 are one rig
    assert expected[("a1", "learned")] != evaluate_skinning(  # the members differ: a swap would show
        root, ["learned"], split="train", names={"a1"}, learned=SHIPPED.overridden(tmp_path / "alone_b1.safetensors")
    ).rows[0].metrics["l1"]
    plain = tmp_path / "plain.safetensors"
    save_weights(whole, plain, {"members": facts[:1]})
    with pytest.raises(InvalidInput, match="no member trained without"):
        stored_members_cv(plain, root, tmp_path / "plain", lambda done, total: None)


def test_eval_skin_scores_the_model_it_is_given(tmp_path: Path) -> None:
    """`eval skin --model PATH` reaches the model loader: a corrupt file fails the learned rows with its code,
    while the shipped model skins the same rig."""
    import json

    root = corpus(tmp_path, [("a1", "train", "family=fa")])
    corrupt = tmp_path / "corrupt.safetensors"
    corrupt.write_bytes(b"not a safetensors file")
    rows = {}
    for label, extra in (("shipped", []), ("corrupt", ["--model", str(corrupt)])):
        out = tmp_path / f"{label}.json"
        result = CliRunner().invoke(app, ["eval", "skin", str(root / "rigged"), "--method", "learned", "--json", str(out), *extra])
        assert result.exit_code == 0, result.output
        rows[label] = json.loads(out.read_text())["assets"]
    assert "error" not in rows["shipped"][0] and rows["shipped"][0]["l1"] is not None
    assert rows["corrupt"][0]["error"].startswith("model_unavailable")
