"""Progress for long CLI work: a rich bar on a terminal, one plain line per change elsewhere."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TaskProgressColumn, TextColumn, TimeElapsedColumn


@contextmanager
def stage_bar(title: str) -> Iterator:
    """Yields update(stage, fraction 0..1): a bar on a terminal, else one plain line per stage change (CI logs, files)."""
    console = Console()
    if not console.is_terminal:
        last: str | None = None

        def line(stage: str, fraction: float) -> None:
            nonlocal last
            if stage != last:
                last = stage
                print(f"{title} {stage} {fraction:.0%}", flush=True)

        yield line
        return
    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), TaskProgressColumn(), TextColumn("{task.fields[stage]}"),
                  TimeElapsedColumn(), transient=False, console=console) as bar:
        task = bar.add_task(title, total=1.0, stage="")

        def update(stage: str, fraction: float) -> None:
            bar.update(task, completed=fraction, stage=stage)

        yield update


@contextmanager
def count_bar(title: str) -> Iterator:
    """Yields update(note, done, total): a bar on a terminal, else one plain line per update (CI logs, files)."""
    console = Console()
    if not console.is_terminal:
        def line(note: str, done: int, total: int) -> None:
            print(f"{title} {done}/{total} {note}", flush=True)

        yield line
        return
    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), TextColumn("{task.fields[note]}"),
                  TimeElapsedColumn(), transient=False, console=console) as bar:
        task = bar.add_task(title, total=None, note="")

        def update(note: str, done: int, total: int) -> None:
            bar.update(task, completed=done, total=total, note=note)

        yield update
