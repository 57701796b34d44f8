"""The training characters every learned model draws on, and the per-character jobs that turn them into samples.

Sources: the corpus (`MANIFEST.tsv` split `train` for training, `val` for model selection) with each file's own
clips, `anny` bodies and procedural creatures (`creature_bodies`; both train only, `anny` imported only when
bodies are asked for). Deterministic by seed: character i of a source draws from default_rng([seed, source, i]).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from functools import partial
from pathlib import Path

import numpy as np

from simcore.errors import SimcoreError
from simcore.evaluation.assets import rigged_assets
from simcore.evaluation.skin_eval import clip_skin_matrices
from simcore.metrics.skinning import unit_cube_frame
from simcore.skeleton.types import Skeleton
from simcore.training.anny_bodies import RIGS, anny_bodies
from simcore.training.creature_bodies import creature_character, creature_name
from simcore.training.sample_cache import Job
from simcore.training.skin_samples import Character

CORPUS = "../shared/corpus"  # the training corpus, beside the repository (both data sections' default)

Make = Callable[[Character, np.random.Generator], Iterable[Mapping[str, np.ndarray]]]


def corpus_characters(root: Path, split: str, skipped: dict[str, str]) -> Iterator[Character]:
    """The split's characters in their unit cube, with their clips' skinning matrices when they have clips."""
    for name, category, doc, asset in rigged_assets(root, skipped, split=split):
        centre, side = unit_cube_frame(asset.vertices)
        try:
            clips = clip_skin_matrices(doc, asset)
        except (SimcoreError, ValueError, np.linalg.LinAlgError):
            clips = None
        if clips is not None and not np.all(np.isfinite(clips)):
            clips = None
        skeleton = Skeleton((asset.skeleton.positions - centre) / side, asset.skeleton.parents, asset.skeleton.names)
        yield Character(name, category, (asset.vertices - centre) / side, asset.faces, skeleton, asset.weights, clips)


def character_jobs(corpus: Path, seed: int, bodies: int, skipped: dict[str, str], *, train: Make, val: Make,
                   body: Make, rigs: Sequence[str] = RIGS, creatures: int = 0) -> tuple[Iterator[Job], int]:
    """(jobs for sample_cache.fill_cache, their count): corpus train characters made by `train`, corpus val by
    `val`, then `bodies` anny bodies by `body`, in anny's `rigs` taken in turn, then `creatures` procedural
    creatures by `body` (each built inside its job, so the build runs on the cache's workers)."""

    sources = [list(corpus_characters(corpus, "train", skipped)), list(corpus_characters(corpus, "val", skipped))]

    def job(split: str, make: Make, c: Character, rng: np.random.Generator) -> Job:
        return split, c.name, partial(make, c, rng)

    def jobs() -> Iterator[Job]:
        for source, (split, make) in enumerate((("train", train), ("val", val))):
            for i, c in enumerate(sources[source]):
                yield job(split, make, c, np.random.default_rng([seed, source, i]))
        people = anny_bodies(bodies, np.random.default_rng([seed, 2]), rigs) if bodies else iter(())
        for i, c in enumerate(people):
            yield job("train", body, c, np.random.default_rng([seed, 3, i]))
        for i in range(creatures):
            yield "train", creature_name(i), partial(built_creature, i, np.random.default_rng([seed, 4, i]), body)

    return jobs(), len(sources[0]) + len(sources[1]) + bodies + creatures


def built_creature(k: int, rng: np.random.Generator, make: Make) -> Iterable[Mapping[str, np.ndarray]]:
    """Samples `make` draws from procedural creature k, built from the same generator."""
    return make(creature_character(k, rng), rng)
