"""What the cross-validations by source family (`rigforge train skin-cv`, `train skeleton-cv`) share: their options,
their table (one section per fold, one per category over all folds, then all; one row per method) and cv.json."""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Annotated, Any, TypeVar

import typer
from rich.console import Console
from rich.table import Table

from cli.train import corpus_of, read_config, train_section

T = TypeVar("T")

FoldsOption = Annotated[int, typer.Option(min=2, help="groups of corpus train families, each held out once")]
StepsOption = Annotated[int | None, typer.Option(min=1, help="training steps per fold (default: the config's)")]
FoldWorkersOption = Annotated[int, typer.Option(min=1, help="folds trained at once (processes)")]
OUT_HELP = "folder for the fold models, logs and cv.json"


def fold_recipe(config: Path, model_config: Callable[..., object], train_config: Callable[..., T], steps: int | None,
                out: Path) -> tuple[dict, T, Path]:
    """(the config, its train section with `steps` per fold when given, its corpus); makes `out`."""
    spec = read_config(config)
    train: Any = train_section(spec, model_config, train_config)
    if steps is not None:
        train = replace(train, steps=steps)
    out.mkdir(parents=True, exist_ok=True)
    return spec, train, corpus_of(spec)


def render_folds(result: dict, console: Console, title: str, heads: Sequence[str], cells: Callable[[dict], list[str]],
                 wins: str) -> None:
    """Print `result` (folds, summary) as one table whose metric columns are `heads`, filled by `cells(mean)`;
    then `wins` and the summary's errors."""
    table = Table(title=title)
    for head in ("fold / category", "method"):
        table.add_column(head)
    for head in heads:
        table.add_column(head, justify="right")
    summary = result["summary"]
    sections = [(f"fold {f['fold']} ({len(f['held_out'])} held out, best step {f['best_step']})", f["mean"])
                for f in result["folds"]]
    sections += [(f"ALL ({c})", means) for c, means in summary["by_category"].items()]
    sections.append(("ALL", summary["mean"]))
    for name, means in sections:
        for i, (method, mean) in enumerate(means.items()):
            table.add_row(name if i == 0 else "", method, *cells(mean), end_section=i == len(means) - 1,
                          style="bold" if name == "ALL" else None)
    console.print(table)
    console.print(wins)
    for error in summary["errors"]:
        console.print(f"[red]error[/] {error}")


def show_and_write(result: dict, out: Path, render: Callable[[dict, Console], None]) -> None:
    """Print `result` with `render` (whole rows when piped) and write it to out/cv.json."""
    console = Console() if Console().is_terminal else Console(width=150)
    render(result, console)
    (out / "cv.json").write_text(json.dumps(result, indent=1))
    console.print(f"wrote {out / 'cv.json'}")
