"""Family cross-validation of the skeleton recipe (`rigforge train skeleton-cv`): each fold's model is trained
without its held-out characters and predicts their skeletons through the `learned` method, beside `auto`."""

from __future__ import annotations

import io
import json
from dataclasses import asdict, replace
from pathlib import Path

import pytest
from rich.console import Console
from typer.testing import CliRunner

from cli.main import app
from cli.train_skeleton_cv import render
from simcore.evaluation.skeleton_eval import evaluate_directory
from simcore.skeleton.learned_model import SkeletonModelConfig
from simcore.training.skeleton_dataset import SkeletonDataConfig, build_skeleton_data
from simcore.training.skeleton_family_cv import family_cv
from simcore.training.skeleton_train import SkeletonTrainConfig, load_skeleton_samples
from tests.simcore.training.corpus_fixture import assert_each_held_out_once, corpus

TINY = SkeletonModelConfig(width=32, heads=2, encoder_layers=1, decoder_layers=2, queries=32, max_tokens=128, frequencies=4)


def test_every_train_character_is_scored_once_by_a_model_that_never_saw_it(tmp_path: Path) -> None:
    root = corpus(tmp_path, [("a1", "train", "family=fa"), ("a2", "train", "family=fa"), ("b1", "train", "family=fb"),
                             ("c1", "train", "family=fc"), ("v1", "val", "family=fv")])
    cache = tmp_path / "cache"
    build_skeleton_data(SkeletonDataConfig(corpus=str(root), variants=2, anny_bodies=0, points=256, max_tokens=128),
                        cache, lambda name, done, total: None)
    assert len(load_skeleton_samples(cache / "train", 128, exclude={"a1", "a2"})) == 4  # b1 and c1, two variants each
    config = SkeletonTrainConfig(steps=3, batch=2, points=128, val_every=3, decode_every=3, decode_val=1, log_every=1,
                                 threads=1, model=TINY)
    reports: list[tuple[int, int]] = []
    result = family_cv(config, cache, root, 2, tmp_path / "cv", 1, lambda done, total: reports.append((done, total)))
    assert_each_held_out_once(result, "auto", ["a1", "a2", "b1", "c1"], 2, reports, 6)
    # A held-out row is what `eval skeleton --method learned --model <that fold's file>` gives for the character.
    fold = next(f for f in result["folds"] if f["held_out"] == ["a1", "a2"])
    alone = evaluate_directory(root, "learned", split="train", names={"a1"},
                               learned_model=tmp_path / "cv" / f"fold_{fold['fold']}.safetensors")
    row = next(r for r in result["assets"] if r["name"] == "a1" and r["method"] == "learned")
    assert alone.results[0].scores is not None and row["j2j"] == pytest.approx(alone.results[0].scores.j2j, abs=1e-6)
    out = io.StringIO()
    render(result, Console(file=out, width=160))
    assert "of 4 held-out characters" in out.getvalue() and "ALL (humanoid)" in out.getvalue()
    # The command reads the corpus from the config's skeleton data section and writes cv.json.
    spec = {"cache": str(cache), "data": {"corpus": str(root), "max_tokens": 128},
            "train": {**asdict(replace(config, steps=1)), "model": asdict(TINY)}}
    (tmp_path / "config.json").write_text(json.dumps(spec))
    command = CliRunner().invoke(app, ["train", "skeleton-cv", "--config", str(tmp_path / "config.json"), "--folds", "2",
                                       "--out", str(tmp_path / "cli")])
    assert command.exit_code == 0, command.output
    written = json.loads((tmp_path / "cli" / "cv.json").read_text())
    assert sorted(r["name"] for r in written["assets"] if r["method"] == "learned") == ["a1", "a2", "b1", "c1"]


def test_excluded_characters_leave_the_training_samples(tmp_path: Path) -> None:
    """The exclusion is by character (`<character>_<k>.npz`), so a name that only starts like another stays."""
    root = corpus(tmp_path, [("a", "train", ""), ("a_b", "train", ""), ("v1", "val", "")])
    cache = tmp_path / "cache"
    build_skeleton_data(SkeletonDataConfig(corpus=str(root), variants=1, anny_bodies=0, points=64), cache,
                        lambda name, done, total: None)
    assert len(load_skeleton_samples(cache / "train", 512)) == 2
    assert len(load_skeleton_samples(cache / "train", 512, exclude={"a"})) == 1
