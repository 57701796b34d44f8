"""The sample cache shared by the model builders: characters in, .npz samples out, one failure skipped, not fatal.

Layout: out/data_config.json, out/train/<name>_<k>.npz, out/val/<name>_<k>.npz, out/summary.json (counts and the
characters skipped with why). A character whose first sample exists is kept as it is (delete the folder to rebuild).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path

import numpy as np

from simcore.errors import SimcoreError

Job = tuple[str, str, Callable[[], Iterable[Mapping[str, np.ndarray]]]]  # (split, character name, make its samples)


def save_sample(path: Path, arrays: Mapping[str, np.ndarray]) -> None:
    """Write one sample's arrays as .npz, atomically (a killed build never leaves half a file)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npz")
    np.savez(tmp, **arrays)  # type: ignore[arg-type]  # numpy's stub: ** could fill allow_pickle (bool)
    tmp.replace(path)


def fill_cache(out: Path, config: dict, jobs: Iterable[Job], total: int, skipped: dict[str, str],
               report: Callable[[str, int, int], None]) -> dict:
    """Run every job not cached yet; report(name, done, total) after each. Returns and writes the summary."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "data_config.json").write_text(json.dumps(config, indent=2))
    counts = {"train": 0, "val": 0, "failed": 0}
    for done, (split, name, make) in enumerate(jobs, start=1):
        if not (out / split / f"{name}_00.npz").exists():
            try:
                for k, arrays in enumerate(make()):
                    save_sample(out / split / f"{name}_{k:02d}.npz", arrays)
            except (SimcoreError, ValueError, np.linalg.LinAlgError) as exc:  # one bad character is skipped
                skipped[name] = f"{type(exc).__name__}: {exc}"[:200]
                counts["failed"] += 1
        counts[split] += len(list((out / split).glob(f"{name}_[0-9][0-9].npz")))
        report(name, done, total)
    summary = {**counts, "skipped": skipped}
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    return summary
