"""Cross-validation by source family: how a learned skinning recipe does on families it never trained on.

Corpus `val` holds 18 characters from 3 families, so one family's conventions (the astronauts' gun bound to a
finger) move its mean by more than most changes to the recipe. Here the recipe is trained `folds` times on the
cached training samples, each time without one group of train families (`assets.family_folds`: no family in two
groups), and each model skins its held-out characters as `rigforge eval skin` does (bind pose, artist skeleton, the
full post-processing) beside the geodesic method: every train character is scored by a model that never saw its
family, 82 characters from 33 families. Early stopping inside each fold still reads `val`, as the shipped recipe
does. Folds run on `workers` processes (spawned; each trains on `config.threads` threads).

`stored_members_cv` scores the fold members an ensemble weights file already holds (simcore/training/skin_ensemble.py
trains them on these same groups) without training: with the config's fold steps they are the models `family_cv`
would train, so a choice made at inference (the prior's share) is checked by held-out family in minutes.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

from simcore.errors import InvalidInput
from simcore.evaluation.assets import family_folds
from simcore.evaluation.skin_eval import SkinEvaluation, evaluate_skinning
from simcore.model_weights import read_metadata, save_weights
from simcore.skinning.learned import SHIPPED, load_model
from simcore.training.fold_pool import run_folds
from simcore.training.skin_train import TrainConfig, train_without

METHODS = ("learned", "geodesic")


def run_fold(fold: int, progress: Any, *, groups: list[list[str]], config: TrainConfig, cache: Path, corpus: Path,
             out: Path, prior_share: float | None = None) -> tuple[dict, SkinEvaluation]:
    """Train without `groups[fold]` (one fold's held-out characters), then skin them with that model (its output times
    the geodesic prior to `prior_share`, None: the shipped share) and with geodesic. `progress`: a queue that gets
    (fold, step) as training goes (fold_pool.run_folds). Returns (the fold's facts, its evaluation)."""
    names = groups[fold]
    model = out / f"fold_{fold}.safetensors"
    summary = train_without(fold, progress, names, config.steps, config, cache, model)
    return score_fold(fold, summary, names, model, corpus, prior_share)


def score_fold(fold: int, summary: dict, names: list[str], model: Path, corpus: Path,
               prior_share: float | None) -> tuple[dict, SkinEvaluation]:
    """Skin the held-out train characters `names` with the fold's `model` (times the geodesic prior to `prior_share`)
    and with geodesic; `summary`: the fold's training figures. Returns (the fold's facts, its evaluation)."""
    evaluation = evaluate_skinning(corpus, list(METHODS), split="train", names=set(names),
                                   learned=SHIPPED.overridden(model, prior_share))
    facts = {"fold": fold, "held_out": names, "best_step": summary["best_step"], "trainer_val": summary["val"],
             "train_samples": summary["train_samples"], "mean": {m: evaluation.mean(m) for m in METHODS}}
    return facts, evaluation


def summarise(merged: SkinEvaluation) -> dict:
    """Means over every held-out character of all folds, per method and per category, and how often learned wins."""
    categories = sorted({r.category for r in merged.rows})
    by_category = {c: {m: merged.mean(m, {r.name for r in merged.rows if r.category == c}) for m in METHODS}
                   for c in categories}
    l1 = {m: {r.name: float(v) for r in merged.rows if r.method == m and (v := r.metrics.get("l1")) is not None}
          for m in METHODS}
    both = sorted(set(l1["learned"]) & set(l1["geodesic"]))
    wins = sum(l1["learned"][n] < l1["geodesic"][n] for n in both)
    return {"mean": {m: merged.mean(m) for m in METHODS}, "by_category": by_category,
            "learned_wins_l1": wins, "compared": len(both),
            "errors": [f"{r.name} {r.method}: {r.error}" for r in merged.rows if r.error]}


def family_cv(config: TrainConfig, cache: Path, corpus: Path, folds: int, out: Path, workers: int,
              report: Callable[[int, int], None], prior_share: float | None = None) -> dict:
    """Run every fold (see the module docstring); report(steps done, steps in all) as training goes. Returns
    {"folds": [facts...], "assets": [row...], "summary": {...}} and writes nothing but each fold's model and log
    under `out`."""
    groups = family_folds(corpus, "train", folds)
    job = partial(run_fold, groups=groups, config=config, cache=cache, corpus=corpus, out=out, prior_share=prior_share)
    return merged_result(run_folds(job, [config.steps] * folds, workers, report))


def stored_members_cv(weights: Path, corpus: Path, out: Path, report: Callable[[int, int], None],
                      prior_share: float | None = None) -> dict:
    """`family_cv`'s result for the members of the ensemble file `weights` that were trained without a group of train
    families: each is written to `out` as a plain model and scores its group; report(folds done, folds in all).
    InvalidInput when the file holds no such member."""
    members = read_metadata(weights, "skinning", "skinning")["summary"].get("members", [])
    folds = [(k, member) for k, member in enumerate(members) if member["held_out"]]
    if not folds:
        raise InvalidInput(f"{weights} holds no member trained without a group of families", code="invalid_option",
                           field="members")
    networks = load_model(weights).networks()
    results = []
    for fold, (k, member) in enumerate(folds):
        path = out / f"fold_{fold}.safetensors"
        save_weights(networks[k], path, {"member_of": str(weights), "member": k, "held_out": member["held_out"]})
        results.append(score_fold(fold, member, member["held_out"], path, corpus, prior_share))
        report(fold + 1, len(folds))
    return merged_result(results)


def merged_result(results: list[tuple[dict, SkinEvaluation]]) -> dict:
    """The folds' facts and evaluations as one result: {"folds", "assets", "summary"}."""
    merged = SkinEvaluation([row for _, evaluation in results for row in evaluation.rows],
                            {k: v for _, evaluation in results for k, v in evaluation.skipped.items()})
    return {"folds": [facts for facts, _ in results], "assets": [r.to_dict() for r in merged.rows],
            "summary": summarise(merged)}
