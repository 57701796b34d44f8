"""`rigforge eval parts DIR [--split SPLIT] [--json FILE]`: how the artists' rigs bind separate mesh parts.

Registered in cli/main.py as `eval_app.command("parts")(eval_parts.eval_parts)`.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.console import Console
from rich.table import Table

from cli.eval_output import print_table_and_problems, write_report_json

if TYPE_CHECKING:  # the evaluation reads every rig: loaded when the command runs, not with every `rigforge` call
    from simcore.evaluation.parts_eval import PartStatistics


def _share(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f}"


def render(report: PartStatistics, console: Console) -> None:
    """One row per (size class, joints held)."""
    from simcore.evaluation.parts_eval import MAX_PIECE, RIGID_SHARE

    table = Table(title=f"Separate parts of {report.rigs} artist rigs: a piece's box diagonal is at most {MAX_PIECE} of the "
                        f"mesh's; held: joints inside the part's box; rigid: every vertex on one joint; leaning: at least "
                        f"{RIGID_SHARE} of the part's weight mass on one joint")
    for head in ("size", "held", "parts", "rigs", "rigid", "leaning", "rigid when leaning"):
        table.add_column(head, justify="left" if head in ("size", "held") else "right")
    for row in report.table():
        table.add_row(row["size"], row["held"], str(row["parts"]), str(row["rigs"]), _share(row["rigid"]),
                      str(row["leaning"]), _share(row["rigid_when_leaning"]))
    print_table_and_problems(console, table, report.skipped, ())


def eval_parts(
    directory: Annotated[Path, typer.Argument(exists=True, file_okay=False, help="folder of rigged .glb/.gltf (or the corpus)")],
    split: Annotated[str | None, typer.Option(help="only the files DIR/MANIFEST.tsv lists for this split (train, val)")] = None,
    json_path: Annotated[Path | None, typer.Option("--json", help="write the JSON report (every part) here")] = None,
) -> None:
    """Count how the artists' rigs bind their separate mesh parts (the data behind rigid-part binding)."""
    from simcore.evaluation.parts_eval import part_statistics

    console = Console()
    with console.status("reading…") as status:
        report = part_statistics(directory, split, on_asset=lambda name: status.update(f"reading {name}"))
    render(report, console)
    write_report_json(console, json_path, report.to_dict())
