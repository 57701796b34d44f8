"""`rigforge train data`: the learned skinning model's training and validation samples, cached as .npz.

Sources: the corpus (`MANIFEST.tsv` split `train` for training, `val` for model selection) with each file's
own clips for re-posing, `anny` bodies and, when asked for, procedural creatures (`creature_bodies`; both train
only). Validation samples are the characters as they come (bind pose, no augmentation). Deterministic by seed:
character i of a source draws from default_rng([seed, source, i]). A sample already in the cache is kept (delete the folder to rebuild).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from simcore.training.anny_bodies import check_rigs
from simcore.training.characters import CORPUS, Make, character_jobs
from simcore.training.sample_cache import fill_cache
from simcore.training.skin_samples import Character, make_sample, normalised, variants


@dataclass(frozen=True)
class DataConfig:
    """What `rigforge train data` builds (the JSON config's "data" section)."""

    corpus: str = CORPUS
    variants: int = 6  # augmented copies of each training character
    anny_bodies: int = 48
    anny_variants: int = 2
    anny_rigs: tuple[str, ...] = ("mixamo", "game_engine")  # anny rig conventions, taken in turn (anny_bodies.ALL_RIGS)
    creatures: int = 0  # procedural creatures (`creature_bodies`), made like anny bodies (anny_variants each)
    vertices: int = 3000  # kept per sample
    val_vertices: int = 4000
    pose_degrees: float = 35.0
    reroot: float = 0.0  # chance that a variant loses its armature root (skin_samples.rerooted)
    decimate: float = 0.0  # chance that a variant that is not subdivided is decimated (skin_samples.decimated)
    helpers: bool = False  # joints a character's weights never use own no bone, as in a job keeping a rig (make_sample)
    seed: int = 0

    def __post_init__(self) -> None:
        check_rigs(self.anny_rigs)  # a typo fails here, not after the corpus characters are built


def build_skin_data(config: DataConfig, out: Path, report: Callable[[str, int, int], None],
                    workers: int = 1) -> dict:
    """Write out/train/*.npz and out/val/*.npz (on `workers` processes); report(name, done, total) after each
    character. Returns counts."""
    skipped: dict[str, str] = {}

    def posed(count: int) -> Make:
        def make(c: Character, rng: np.random.Generator) -> list[dict[str, np.ndarray]]:
            augmented = variants(c, rng, count, config.pose_degrees, reroot=config.reroot, decimate=config.decimate)
            return [make_sample(v, rng, config.vertices, helpers=config.helpers).arrays() for v in augmented]
        return make

    jobs, total = character_jobs(
        Path(config.corpus), config.seed, config.anny_bodies, skipped, train=posed(config.variants),
        val=lambda c, rng: [make_sample(normalised(c), rng, config.val_vertices, helpers=config.helpers).arrays()], body=posed(config.anny_variants),
        rigs=config.anny_rigs, creatures=config.creatures)
    return fill_cache(out, asdict(config), jobs, total, skipped, report, workers)
