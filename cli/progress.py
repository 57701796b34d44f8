"""A rich progress bar fed with (stage, fraction) updates."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from rich.progress import BarColumn, Progress, TaskProgressColumn, TextColumn, TimeElapsedColumn


@contextmanager
def stage_bar(title: str) -> Iterator:
    """Yields update(stage, fraction 0..1)."""
    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), TaskProgressColumn(), TextColumn("{task.fields[stage]}"),
                  TimeElapsedColumn(), transient=False) as bar:
        task = bar.add_task(title, total=1.0, stage="")

        def update(stage: str, fraction: float) -> None:
            bar.update(task, completed=fraction, stage=stage)

        yield update
