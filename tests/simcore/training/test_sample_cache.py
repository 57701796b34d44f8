"""The sample cache: a build on several processes writes the same samples as one process, and a failing
character is skipped with its reason either way."""

from __future__ import annotations

from collections.abc import Mapping
from functools import partial
from pathlib import Path

import numpy as np
import pytest

from simcore.errors import InvalidInput
from simcore.training.sample_cache import Job, fill_cache


def _jobs() -> list[Job]:
    def make(seed: int) -> list[Mapping[str, np.ndarray]]:
        rng = np.random.default_rng(seed)  # each job owns its generator, as character_jobs gives them
        return [{"x": rng.normal(size=(5, 3)), "k": np.array(k)} for k in range(2)]

    def broken() -> list[Mapping[str, np.ndarray]]:
        raise InvalidInput("no skin", field="mesh")

    jobs: list[Job] = [("train", f"c{i}", partial(make, i)) for i in range(5)]
    return [*jobs, ("val", "v0", partial(make, 99)), ("train", "bad", broken)]


@pytest.mark.parametrize("workers", [1, 3])
def test_a_forked_build_writes_what_one_process_writes(tmp_path: Path, workers: int) -> None:
    reports: list[int] = []
    serial = fill_cache(tmp_path / "one", {}, _jobs(), 7, {}, lambda name, done, total: None)
    summary = fill_cache(tmp_path / "many", {}, _jobs(), 7, {}, lambda name, done, total: reports.append(done), workers)
    assert summary == serial and summary["train"] == 10 and summary["val"] == 2 and summary["failed"] == 1
    assert "bad" in summary["skipped"] and "no skin" in summary["skipped"]["bad"]
    assert sorted(reports) == list(range(1, 8))
    for path in sorted((tmp_path / "one").rglob("*.npz")):
        with np.load(path) as a, np.load(tmp_path / "many" / path.relative_to(tmp_path / "one")) as b:
            assert np.array_equal(a["x"], b["x"])
