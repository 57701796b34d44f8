"""Cross-validation by source family for the skeleton model: how a recipe does on families it never trained on.

Corpus `val` holds 18 characters from 3 families, and one of them (quaternius-space, 12 of the 18, its mechs and
alien blobs the worst-scored rigs) sets most of its mean, so a recipe change can move val either way by chance.
Here the recipe is trained `folds` times on the cached samples, each time without one group of train families
(`assets.family_folds`: no family in two groups, the same groups as the skinning model's `rigforge train skin-cv`),
and each model's `learned` method predicts skeletons for its held-out characters exactly as `rigforge eval
skeleton --method learned --model` does; `auto` (which no recipe changes) is scored beside it, each file read once
for both. Every train character is then scored by a model that never saw its family: 82 characters from 33
families. Early stopping inside each fold still reads `val`. Folds run on `workers` spawned processes (each trains
on `config.threads` threads).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any

from simcore.evaluation.assets import family_folds
from simcore.evaluation.skeleton_eval import SkeletonEvaluation, evaluate_directory
from simcore.training.fold_pool import run_folds, step_reporter
from simcore.training.skeleton_train import SkeletonTrainConfig, train_skeleton

METHODS = ("learned", "auto")


def run_fold(fold: int, progress: Any, *, groups: list[list[str]], config: SkeletonTrainConfig, cache: Path,
             corpus: Path, out: Path) -> tuple[dict, SkeletonEvaluation]:
    """Train without `groups[fold]` into out/fold_<k>.safetensors (log beside it), then score its held-out
    characters with that model's `learned` method and with `auto`. `progress`: a queue that gets (fold, step) as
    training goes (fold_pool.run_folds). Returns (the fold's facts, its evaluation)."""
    names = groups[fold]
    model = out / f"fold_{fold}.safetensors"
    model.parent.mkdir(parents=True, exist_ok=True)
    summary = train_skeleton(replace(config, exclude=tuple(names)), cache, model, model.with_suffix(".jsonl"),
                             step_reporter(fold, progress))
    evaluation = evaluate_directory(corpus, METHODS, split="train", names=set(names), learned_model=model)
    facts = {"fold": fold, "held_out": names, "best_step": summary["best_step"], "trainer_val": summary["val"],
             "train_samples": summary["train_samples"], "mean": {m: evaluation.mean(m) for m in METHODS}}
    return facts, evaluation


def summarise(merged: SkeletonEvaluation) -> dict:
    """Means over every held-out character of all folds, per method and per category, and on how many characters
    the learned method has the lower J2J than `auto`."""
    j2j = {m: {r.name: r.scores.j2j for r in merged.results if r.method == m and r.scores is not None} for m in METHODS}
    both = sorted(set(j2j["learned"]) & set(j2j["auto"]))
    return {"mean": {m: merged.mean(m) for m in METHODS},
            "by_category": {c: {m: merged.mean(m, c) for m in METHODS} for c in merged.categories()},
            "learned_wins_j2j": sum(j2j["learned"][n] < j2j["auto"][n] for n in both), "compared": len(both),
            "errors": [f"{r.name} {r.method}: {r.error}" for r in merged.results if r.error],
            "skipped": merged.skipped}


def family_cv(config: SkeletonTrainConfig, cache: Path, corpus: Path, folds: int, out: Path, workers: int,
              report: Callable[[int, int], None]) -> dict:
    """Run every fold (module docstring); report(steps done, steps in all) as training goes. Returns {"folds":
    [facts...], "assets": [row...], "summary": {...}}; writes nothing but each fold's model and log under `out`."""
    groups = family_folds(corpus, "train", folds)
    job = partial(run_fold, groups=groups, config=config, cache=cache, corpus=corpus, out=out)
    results = run_folds(job, [config.steps] * folds, workers, report)
    merged = SkeletonEvaluation([row for _, evaluation in results for row in evaluation.results],
                                {k: v for _, evaluation in results for k, v in evaluation.skipped.items()})
    return {"folds": [facts for facts, _ in results], "assets": [r.to_dict() for r in merged.results],
            "summary": summarise(merged)}
