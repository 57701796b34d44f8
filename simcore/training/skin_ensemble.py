"""The family ensemble: the skinning recipe trained on every corpus `train` family, and once more per group of
families, each of those members without its group; saved as one weights file (simcore/skinning/ensemble.py) and
scored on `val` as one model.

Corpus `train` holds a few dozen source families and a single model overfits to them within a few thousand steps
(README, Skinning): what it learns from one family's conventions moves its val score by more than most recipe
changes. Members that each miss a different group of families err differently, and their mean outvotes any one
of them. The groups are those of `rigforge train skin-cv` (`assets.family_folds`), so with the same steps each
group's member is exactly that command's fold model. Each member keeps its own best val state, as a plain run does,
and the file holds them best first by that state's val L1.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from functools import partial
from pathlib import Path
from typing import Any

from simcore.evaluation.assets import family_folds
from simcore.model_weights import save_weights
from simcore.skinning.ensemble import SkinEnsemble
from simcore.skinning.learned import load_member
from simcore.training.fold_pool import run_folds
from simcore.training.skin_train import TrainConfig, evaluate, load_samples, train_without


@dataclass(frozen=True)
class FamilyEnsemble:
    """The JSON config's "ensemble" section: besides the member trained on every family for the train section's
    steps, `folds` members (0: none, one plain model), each without one group of families, trained for `fold_steps`
    (0: the train section's); `workers` members train at once (processes)."""

    folds: int = 0
    fold_steps: int = 0
    workers: int = 1


def train_member(index: int, progress: Any, *, held_out: list[tuple[str, ...]], steps: list[int], config: TrainConfig,
                 cache: Path, folder: Path) -> dict:
    """Train member `index` (folder/member_<index>.safetensors) without `held_out[index]` for `steps[index]` steps."""
    return train_without(index, progress, held_out[index], steps[index], config, cache, folder / f"member_{index}.safetensors")


def train_ensemble(config: TrainConfig, ensemble: FamilyEnsemble, cache: Path, corpus: Path, out: Path, log: Path,
                   report: Callable[[int, int], None]) -> dict:
    """Train the members (their files and logs in a folder beside `log`), save them as one ensemble at `out`, write
    each member's and the ensemble's val scores to `log`. Returns the summary stored with the weights."""
    started = time.perf_counter()
    held_out = [(), *(tuple(g) for g in family_folds(corpus, "train", ensemble.folds))]
    steps = [config.steps] + [ensemble.fold_steps or config.steps] * ensemble.folds
    folder = log.with_name(f"{log.stem}_members")
    job = partial(train_member, held_out=held_out, steps=steps, config=config, cache=cache, folder=folder)
    members = run_folds(job, steps, ensemble.workers, report)
    facts = [{"file": f"member_{k}.safetensors", "held_out": list(h), "steps": s, "best_step": m["best_step"],
              "val": m["val"], "val_at_start": m["val_at_start"], "train_samples": m["train_samples"], "seconds": m["seconds"]}
             for k, (h, s, m) in enumerate(zip(held_out, steps, members))]
    whole = members[0]  # trained on every training sample: the data's size and mix, as a plain run reports them
    return save_ensemble(facts, folder, cache, out, log, {
        "train_samples": whole["train_samples"], "categories": whole["categories"],
        "seconds": round(time.perf_counter() - started, 1), "config": asdict(config), "ensemble": asdict(ensemble)})


def ensemble_of(facts: list[dict], folder: Path) -> SkinEnsemble:
    """The members whose `facts` name their files in `folder`, in that order."""
    return SkinEnsemble([load_member(folder / f["file"]) for f in facts])


def save_ensemble(facts: list[dict], folder: Path, cache: Path, out: Path, log: Path, extra: dict) -> dict:
    """Save the members whose `facts` name their files in `folder` as one ensemble at `out`, ordered by their own val
    L1, best first (a character too large for every member to read it is read by the best ones, learned.PASS_PAIRS);
    score it on the val samples of `cache`; write each member's and the ensemble's scores to `log`. Returns the
    summary stored with the weights (`extra`, the training data's figures among them, added to it)."""
    ordered = sorted(facts, key=lambda f: f["val"]["l1"])
    model = ensemble_of(ordered, folder)
    val, _ = load_samples(cache / "val")
    summary = {"val": evaluate(model, val), "val_at_start": ordered[0]["val_at_start"], "val_samples": len(val),
               "members": ordered, **extra}
    save_weights(model, out, summary)
    with log.open("w", encoding="utf-8") as fh:
        for k, m in enumerate(ordered):
            fh.write(json.dumps({"event": "member", "member": k, **m}) + "\n")
        fh.write(json.dumps({"event": "end", **summary}) + "\n")
    return summary
