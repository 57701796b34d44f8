"""`rigforge train data`: the learned skinning model's training and validation samples, cached as .npz.

Sources: the corpus (`MANIFEST.tsv` split `train` for training, `val` for model selection) with each file's
own clips for re-posing, and `anny` bodies (train only). Validation samples are the characters as they come
(bind pose, no augmentation). Deterministic by seed: character i of a source draws from
default_rng([seed, source, i]). A sample already in the cache is kept (delete the folder to rebuild).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass
from functools import partial
from pathlib import Path

import numpy as np

from simcore.errors import SimcoreError
from simcore.evaluation.assets import rigged_assets
from simcore.evaluation.skin_eval import clip_skin_matrices
from simcore.metrics.skinning import unit_cube_frame
from simcore.skeleton.types import Skeleton
from simcore.training.skin_samples import Character, SkinSample, make_sample, normalised, variants


@dataclass(frozen=True)
class DataConfig:
    """What `rigforge train data` builds (the JSON config's "data" section)."""

    corpus: str = "../shared/corpus"
    variants: int = 6  # augmented copies of each training character
    anny_bodies: int = 48
    anny_variants: int = 2
    vertices: int = 3000  # kept per sample
    val_vertices: int = 4000
    pose_degrees: float = 35.0
    seed: int = 0


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


def _write(path: Path, sample: SkinSample) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npz")
    np.savez(tmp, **sample.arrays())  # type: ignore[arg-type]  # numpy's stub: ** could fill allow_pickle (bool)
    tmp.replace(path)


def build_skin_data(config: DataConfig, out: Path, report: Callable[[str, int, int], None]) -> dict:
    """Write out/train/*.npz and out/val/*.npz; report(name, done, total) after each character. Returns counts."""
    from simcore.training.anny_bodies import anny_bodies

    root = Path(config.corpus)
    out.mkdir(parents=True, exist_ok=True)
    (out / "data_config.json").write_text(json.dumps(asdict(config), indent=2))
    skipped: dict[str, str] = {}
    counts = {"train": 0, "val": 0, "failed": 0}
    train = list(corpus_characters(root, "train", skipped))
    val = list(corpus_characters(root, "val", skipped))
    total = len(train) + len(val) + config.anny_bodies
    done = 0

    def emit(split: str, name: str, make: Callable[[], list[SkinSample]]) -> None:
        nonlocal done
        paths = [out / split / f"{name}_{k:02d}.npz" for k in range(config.variants if split == "train" else 1)]
        if not paths[0].exists():
            try:
                for path, sample in zip(paths, make()):
                    _write(path, sample)
            except (SimcoreError, ValueError, np.linalg.LinAlgError) as exc:  # one bad character is skipped, not fatal
                skipped[name] = f"{type(exc).__name__}: {exc}"[:200]
                counts["failed"] += 1
        counts[split] += sum(p.exists() for p in paths)
        done += 1
        report(name, done, total)

    def posed_samples(c: Character, rng: np.random.Generator, count: int) -> list[SkinSample]:
        return [make_sample(v, rng, config.vertices) for v in variants(c, rng, count, config.pose_degrees)]

    def rest_sample(c: Character, rng: np.random.Generator) -> list[SkinSample]:
        return [make_sample(normalised(c), rng, config.val_vertices)]

    for i, c in enumerate(train):
        rng = np.random.default_rng([config.seed, 0, i])
        emit("train", c.name, partial(posed_samples, c, rng, config.variants))
    for i, c in enumerate(val):
        rng = np.random.default_rng([config.seed, 1, i])
        emit("val", c.name, partial(rest_sample, c, rng))
    bodies = anny_bodies(config.anny_bodies, np.random.default_rng([config.seed, 2])) if config.anny_bodies else iter(())
    for i, c in enumerate(bodies):
        rng = np.random.default_rng([config.seed, 3, i])
        emit("train", c.name, partial(posed_samples, c, rng, config.anny_variants))
    summary = {**counts, "skipped": skipped}
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    return summary
