"""The sample cache shared by the model builders: characters in, .npz samples out, one failure skipped, not fatal.

Layout: out/data_config.json, out/train/<name>_<k>.npz, out/val/<name>_<k>.npz, out/summary.json (counts and the
characters skipped with why). A character whose first sample exists is kept as it is (delete the folder to rebuild).
With `workers` > 1 the characters are built by that many forked processes first; each job carries its own random
generator, so the samples are the same as one process writes.
"""

from __future__ import annotations

import json
import multiprocessing
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path

import numpy as np

from simcore.errors import SimcoreError

Job = tuple[str, str, Callable[[], Iterable[Mapping[str, np.ndarray]]]]  # (split, character name, make its samples)
BUILD_ERRORS = (SimcoreError, ValueError, np.linalg.LinAlgError)  # one character failing this way is skipped
_FORKED: tuple[Path, Sequence[Job]] | None = None  # what the forked builders read (closures cannot be pickled)


def sample_character(path: Path) -> str:
    """The character a cached sample file was made from (`<character>_<k>.npz`, this cache's layout)."""
    return path.stem.rsplit("_", 1)[0]


def save_sample(path: Path, arrays: Mapping[str, np.ndarray]) -> None:
    """Write one sample's arrays as .npz, atomically (a killed build never leaves half a file)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npz")
    np.savez(tmp, **arrays)  # type: ignore[arg-type]  # numpy's stub: ** could fill allow_pickle (bool)
    tmp.replace(path)


def _save_all(out: Path, job: Job) -> None:
    split, name, make = job
    for k, arrays in enumerate(make()):
        save_sample(out / split / f"{name}_{k:02d}.npz", arrays)


def _failure(exc: Exception) -> str:
    return f"{type(exc).__name__}: {exc}"[:200]


def _build_forked(index: int) -> tuple[str, str | None]:
    """(character name, why it failed or None)."""
    assert _FORKED is not None, "set before the pool forks"
    out, jobs = _FORKED
    try:
        _save_all(out, jobs[index])
    except BUILD_ERRORS as exc:
        return jobs[index][1], _failure(exc)
    return jobs[index][1], None


def _build_parallel(out: Path, jobs: Sequence[Job], workers: int, report: Callable[[str, int, int], None]) -> dict[str, str]:
    """Build every job not cached yet on `workers` forked processes; report(name, done, total) as each ends.
    Returns character name → why it failed, for those that did."""
    global _FORKED
    missing = [i for i, (split, name, _) in enumerate(jobs) if not (out / split / f"{name}_00.npz").exists()]
    _FORKED = (out, jobs)
    failed: dict[str, str] = {}
    try:
        with multiprocessing.get_context("fork").Pool(workers) as pool:
            for done, (name, why) in enumerate(pool.imap_unordered(_build_forked, missing), start=len(jobs) - len(missing) + 1):
                if why is not None:
                    failed[name] = why
                report(name, done, len(jobs))
    finally:
        _FORKED = None
    return failed


def fill_cache(out: Path, config: dict, jobs: Iterable[Job], total: int, skipped: dict[str, str],
               report: Callable[[str, int, int], None], workers: int = 1) -> dict:
    """Run every job not cached yet (on `workers` processes); report(name, done, total) after each. Returns and
    writes the summary."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "data_config.json").write_text(json.dumps(config, indent=2))
    failed: dict[str, str] = {}
    if workers > 1:
        jobs = list(jobs)
        failed = _build_parallel(out, jobs, workers, report)
    counts = {"train": 0, "val": 0, "failed": 0}
    for done, (split, name, make) in enumerate(jobs, start=1):
        if name not in failed and not (out / split / f"{name}_00.npz").exists():
            try:
                _save_all(out, (split, name, make))
            except BUILD_ERRORS as exc:  # one bad character is skipped
                failed[name] = _failure(exc)
        if name in failed:
            skipped[name] = failed[name]
            counts["failed"] += 1
        counts[split] += len(list((out / split).glob(f"{name}_[0-9][0-9].npz")))
        if workers == 1:  # the parallel builders already reported each character
            report(name, done, total)
    summary = {**counts, "skipped": skipped}
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    return summary
