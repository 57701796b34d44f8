"""`rigforge train skin-cv --config CONFIG`: the skinning recipe cross-validated by source family.

Registered in cli/main.py as `rigforge train skin-cv`. Trains the config's recipe once per fold of corpus `train`
families, on the config's sample cache (build it first with `rigforge train data --config CONFIG`), and scores each
fold's held-out characters against the geodesic method (simcore/training/skin_family_cv.py). Prints a table,
writes OUT/cv.json; the fold models and logs stay under OUT. With `--members WEIGHTS` nothing is trained: the fold
members stored in an ensemble file (the shipped one: simcore/skinning/weights/skin_attention.safetensors) score the
families they never saw, e.g. to check a prior share in minutes.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from cli.eval_skin import METRIC_HEADS, PRIOR_SHARE_HELP, metric_cells
from cli.family_cv import OUT_HELP, FoldsOption, FoldWorkersOption, StepsOption, fold_recipe, render_folds, show_and_write
from cli.progress import count_bar
from cli.train import DEFAULT_CONFIG, ConfigOption


def render(result: dict, console: Console) -> None:
    """Per fold and overall (per category): learned against geodesic on the held-out characters."""
    summary = result["summary"]
    render_folds(result, console, "Skinning by held-out source family (deformation in unit-cube units: random poses | "
                 "own clips)", ("assets", *METRIC_HEADS), lambda mean: [str(mean["assets"]), *metric_cells(mean)],
                 f"learned has the lower L1 on {summary['learned_wins_l1']} of {summary['compared']} held-out characters")


def skin_cv(
    config: ConfigOption = DEFAULT_CONFIG,
    folds: FoldsOption = 5,
    steps: StepsOption = None,
    workers: FoldWorkersOption = 1,
    out: Annotated[Path, typer.Option(help=OUT_HELP)] = Path(".rigforge-train/skin_cv"),
    prior_share: Annotated[float | None, typer.Option(min=0.0, max=1.0, help=PRIOR_SHARE_HELP)] = None,
    members: Annotated[Path | None, typer.Option(exists=True, dir_okay=False, help=(
        "score the fold members stored in this ensemble weights file instead of training "
        "(folds, steps and workers are then the file's)"))] = None,
) -> None:
    """Cross-validate the skinning recipe by source family: every train character scored by a model that never
    saw its family, beside the geodesic method."""
    from simcore.skinning.attention_model import ModelConfig
    from simcore.training.skin_family_cv import family_cv, stored_members_cv
    from simcore.training.skin_train import TrainConfig

    spec, train, corpus = fold_recipe(config, ModelConfig, TrainConfig, steps, out)
    if members is not None:
        with count_bar("scoring stored folds") as update:
            result = stored_members_cv(members, corpus, out, lambda done, total: update("", done, total), prior_share)
    else:
        with count_bar("training folds") as update:
            result = family_cv(train, Path(spec["cache"]), corpus, folds, out, workers,
                               lambda done, total: update("", done, total), prior_share)
    show_and_write(result, out, render)
