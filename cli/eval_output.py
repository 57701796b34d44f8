"""Shared tail of the eval commands' output: the table, skipped assets and failed rows."""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path

from rich.console import Console
from rich.table import Table


def print_table_and_problems(console: Console, table: Table, skipped: dict[str, str], failures: Iterable[str]) -> None:
    """Print `table`, then one line per skipped asset and one red line per failed row."""
    console.print(table)
    for name, reason in skipped.items():
        console.print(f"skipped {name}: {reason}")
    for failure in failures:
        console.print(f"[red]{failure}[/red]")


def write_report_json(console: Console, path: Path | None, report: dict) -> None:
    """Write the eval's JSON report when --json was given, and say where."""
    if path is None:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(report, indent=1))
    console.print(f"wrote {path}")
