"""`rigforge train skeleton-cv --config CONFIG`: the skeleton recipe cross-validated by source family.

Registered in cli/main.py as `rigforge train skeleton-cv`. Trains the config's recipe once per fold of corpus
`train` families on the config's sample cache (build it first with `rigforge train skeleton-data --config CONFIG`)
and scores each fold's held-out characters with its `learned` method beside `auto`
(simcore/training/skeleton_family_cv.py). Prints a table, writes OUT/cv.json; the fold models and logs stay under OUT.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from cli.eval_skeleton import metric_cells
from cli.family_cv import OUT_HELP, FoldsOption, FoldWorkersOption, StepsOption, fold_recipe, render_folds, show_and_write
from cli.progress import count_bar
from cli.train import SKELETON_CONFIG, ConfigOption


def _cells(mean: dict) -> list[str]:
    ratio = f"{mean['joint_ratio_ok']:.0%}" if "joint_ratio_ok" in mean else "-"
    return [str(mean["assets"]), *metric_cells(mean), ratio]


def render(result: dict, console: Console) -> None:
    """Per fold and overall (per category): the learned method against auto on the held-out characters."""
    summary = result["summary"]
    render_folds(result, console, "Skeletons by held-out source family (unit-cube units)",
                 ("assets", "J2J", "J2B", "B2B", "joints pred/gt", "inside", "joints 0.5-2x"), _cells,
                 f"learned has the lower J2J on {summary['learned_wins_j2j']} of {summary['compared']} held-out characters")
    for name, reason in summary["skipped"].items():
        console.print(f"skipped {name}: {reason}")


def skeleton_cv(
    config: ConfigOption = SKELETON_CONFIG,
    folds: FoldsOption = 5,
    steps: StepsOption = None,
    workers: FoldWorkersOption = 1,
    out: Annotated[Path, typer.Option(help=OUT_HELP)] = Path(".rigforge-train/skeleton_cv"),
) -> None:
    """Cross-validate the skeleton recipe by source family: every train character's skeleton predicted by a model
    that never saw its family, beside `auto`."""
    from simcore.skeleton.learned_model import SkeletonModelConfig
    from simcore.training.skeleton_family_cv import family_cv
    from simcore.training.skeleton_train import SkeletonTrainConfig

    spec, train, corpus = fold_recipe(config, SkeletonModelConfig, SkeletonTrainConfig, steps, out)
    with count_bar("training folds") as update:
        result = family_cv(train, Path(spec["cache"]), corpus, folds, out, workers,
                           lambda done, total: update("", done, total))
    show_and_write(result, out, render)
