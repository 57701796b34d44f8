"""Structured job warnings: the one list every stage and quality check writes to.

It is report.json's "warnings" and the job row's `warnings`: entries {code, stage, message, figure, threshold,
hard, frame}. `hard` marks a figure past its failing threshold; `frame` the worst animation frame, if any.
"""

from __future__ import annotations

from typing import Any


def add_warning(report: dict[str, Any], *, code: str, stage: str, message: str, figure: float | None = None,
                threshold: float | None = None, hard: bool = False, frame: int | None = None) -> dict[str, Any]:
    """Append one warning to report["warnings"] and return it."""
    entry = {"code": code, "stage": stage, "message": message, "figure": figure, "threshold": threshold,
             "hard": hard, "frame": frame}
    report.setdefault("warnings", []).append(entry)
    return entry
