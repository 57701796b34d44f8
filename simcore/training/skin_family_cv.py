"""Cross-validation by source family: how a learned skinning recipe does on families it never trained on.

Corpus `val` holds 18 characters from 3 families, so one family's conventions (the astronauts' gun bound to a
finger) move its mean by more than most changes to the recipe. Here the recipe is trained `folds` times on the
cached training samples, each time without one group of train families (`assets.family_folds`: no family in two
groups), and each model skins its held-out characters as `rigforge eval skin` does (bind pose, artist skeleton, the
full post-processing) beside the geodesic method: every train character is scored by a model that never saw its
family, 82 characters from 33 families. Early stopping inside each fold still reads `val`, as the shipped recipe
does. Folds run on `workers` processes (spawned; each trains on `config.threads` threads).
"""

from __future__ import annotations

import multiprocessing
import queue
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import replace
from pathlib import Path
from typing import Any

from simcore.evaluation.assets import family_folds
from simcore.evaluation.skin_eval import SkinEvaluation, evaluate_skinning
from simcore.skinning.learned import SHIPPED
from simcore.training.skin_train import TrainConfig, train_skin

METHODS = ("learned", "geodesic")
POLL_S = 1.0


def run_fold(fold: int, names: list[str], config: TrainConfig, cache: Path, corpus: Path, out: Path,
             prior_share: float | None = None, progress: Any = None) -> tuple[dict, SkinEvaluation]:
    """Train without `names` (one fold's held-out characters), then skin them with that model (its output times the
    geodesic prior to `prior_share`, None: the shipped share) and with geodesic. `progress`: a queue that gets
    (fold, step) as training goes. Returns (the fold's facts, its evaluation)."""
    folder = out / f"fold_{fold}"
    folder.mkdir(parents=True, exist_ok=True)
    model = folder / "skin_attention.safetensors"

    def report(step: int, total: int, entry: dict) -> None:
        if progress is not None:
            progress.put((fold, step))

    summary = train_skin(replace(config, exclude=tuple(names)), cache, model, folder / "log.jsonl", report)
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
    done, reported = [0] * folds, -1
    context = multiprocessing.get_context("spawn")  # torch in a forked child of a process that used it can hang
    with context.Manager() as manager, ProcessPoolExecutor(workers, mp_context=context) as pool:
        progress = manager.Queue()
        pending: set[Future] = {pool.submit(run_fold, k, g, config, cache, corpus, out, prior_share, progress) for k, g in enumerate(groups)}
        results: list[tuple[dict, SkinEvaluation]] = []
        while pending:
            finished, pending = wait(pending, timeout=POLL_S, return_when=FIRST_COMPLETED)
            results.extend(f.result() for f in finished)
            try:
                while True:
                    fold, step = progress.get_nowait()
                    done[fold] = step
            except queue.Empty:
                pass
            if sum(done) != reported:  # one report per change (a plain log gets one line each)
                reported = sum(done)
                report(reported, folds * config.steps)
    results.sort(key=lambda r: r[0]["fold"])
    merged = SkinEvaluation([row for _, evaluation in results for row in evaluation.rows],
                            {k: v for _, evaluation in results for k, v in evaluation.skipped.items()})
    return {"folds": [facts for facts, _ in results], "assets": [r.to_dict() for r in merged.rows],
            "summary": summarise(merged)}
