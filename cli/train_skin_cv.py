"""`rigforge train skin-cv --config CONFIG`: the skinning recipe cross-validated by source family.

Registered in cli/main.py as `rigforge train skin-cv`. Trains the config's recipe once per fold of corpus `train`
families, on the config's sample cache (build it first with `rigforge train data --config CONFIG`), and scores each
fold's held-out characters against the geodesic method (simcore/training/skin_family_cv.py). Prints a table,
writes OUT/cv.json; the fold models and logs stay under OUT. With `--members WEIGHTS` nothing is trained: the fold
members stored in an ensemble file (the shipped one: simcore/skinning/weights/skin_attention.safetensors) score the
families they never saw, e.g. to check a prior share in minutes.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from cli.eval_skin import METRIC_HEADS, PRIOR_SHARE_HELP, metric_cells
from cli.fold_table import render_folds
from cli.progress import count_bar
from cli.train import DEFAULT_CONFIG, ConfigOption, corpus_of, read_config, train_section


def render(result: dict, console: Console) -> None:
    """Per fold and overall (per category): learned against geodesic on the held-out characters."""
    summary = result["summary"]
    render_folds(result, console, "Skinning by held-out source family (deformation in unit-cube units: random poses | "
                 "own clips)", ("assets", *METRIC_HEADS), lambda mean: [str(mean["assets"]), *metric_cells(mean)],
                 f"learned has the lower L1 on {summary['learned_wins_l1']} of {summary['compared']} held-out characters")


def skin_cv(
    config: ConfigOption = DEFAULT_CONFIG,
    folds: Annotated[int, typer.Option(min=2, help="groups of corpus train families, each held out once")] = 5,
    steps: Annotated[int | None, typer.Option(min=1, help="training steps per fold (default: the config's)")] = None,
    workers: Annotated[int, typer.Option(min=1, help="folds trained at once (processes)")] = 1,
    out: Annotated[Path, typer.Option(help="folder for the fold models, logs and cv.json")] = Path(".rigforge-train/skin_cv"),
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

    spec = read_config(config)
    train = train_section(spec, ModelConfig, TrainConfig)
    if steps is not None:
        train = replace(train, steps=steps)
    corpus = corpus_of(spec)
    out.mkdir(parents=True, exist_ok=True)
    if members is not None:
        with count_bar("scoring stored folds") as update:
            result = stored_members_cv(members, corpus, out, lambda done, total: update("", done, total), prior_share)
    else:
        with count_bar("training folds") as update:
            result = family_cv(train, Path(spec["cache"]), corpus, folds, out, workers,
                               lambda done, total: update("", done, total), prior_share)
    console = Console() if Console().is_terminal else Console(width=150)
    render(result, console)
    (out / "cv.json").write_text(json.dumps(result, indent=1))
    console.print(f"wrote {out / 'cv.json'}")
