"""The table of a cross-validation by source family (`rigforge train skin-cv`, `train skeleton-cv`): one section per
fold, one per category over all folds, then all; one row per method."""

from __future__ import annotations

from collections.abc import Callable, Sequence

from rich.console import Console
from rich.table import Table


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
