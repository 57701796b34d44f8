"""`rigforge train skeleton-data`: the learned skeleton model's samples, cached as .npz.

Same characters and augmentations as the skinning model's data (`characters.corpus_characters`,
`anny_bodies`, `skin_samples.variants`): corpus `train` (re-posed by its clips and random poses, subdivided),
corpus `val` as it comes (bind pose), anny bodies and procedural creatures (`creature_bodies`; train only).
The skeleton model keeps the upload's facing, so variants are turned by at most ±`turn_degrees` about up
instead of a full turn (scale does not matter: the tokens are normalised). A sample is `points` surface points
with normals in the token frame, the class token and the token sequence of the character's used skin joints
(those the evaluation scores against).

Classes (the vocabulary's four UniRig slots): `mixamo` for a skeleton whose body matches the Mixamo template
(anny's Mixamo rig, Mixamo-named corpus rigs), `vroid` for anny's game-engine rig (the second humanoid
convention takes UniRig's other humanoid slot), `none` (the slot left) for procedural creatures, whose bone-tube
convention is not an artist's, and `articulation` for every other corpus rig.
Deterministic by seed: character i of a source draws from default_rng([seed, source, i]).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from simcore.io.gltf_rig import used_joints
from simcore.metrics.skeleton import used_skeleton
from simcore.skeleton.shape_points import shape_points
from simcore.skeleton.tokenizer import SkeletonTokenizer
from simcore.skeleton.types import Skeleton
from simcore.training import creature_bodies
from simcore.training.characters import CORPUS, Make, character_jobs
from simcore.training.sample_cache import fill_cache
from simcore.training.skin_samples import Character, normalised, variants

GAME_ENGINE_PREFIX = "anny_game_engine"  # anny_bodies names each body after its rig


@dataclass(frozen=True)
class SkeletonDataConfig:
    """What `rigforge train skeleton-data` builds (the JSON config's "data" section)."""

    corpus: str = CORPUS
    variants: int = 8  # augmented copies of each training character
    anny_bodies: int = 64
    anny_variants: int = 3
    creatures: int = 0  # procedural creatures (`creature_bodies`), made like anny bodies (anny_variants each)
    points: int = 4096  # surface points kept per sample (training draws a subset each step)
    pose_degrees: float = 35.0
    turn_degrees: float = 30.0  # largest turn about up either way
    max_tokens: int = 512
    seed: int = 0


@dataclass
class SkeletonSample:
    """points (P, 6) float32 token-frame points and normals; tokens (L,) int64; joints (J, 3) float32 the target
    joints in the token frame (for decoded J2J); category of the character."""

    points: np.ndarray
    tokens: np.ndarray
    joints: np.ndarray
    category: str

    def arrays(self) -> dict[str, np.ndarray]:
        """Flat name → array mapping for np.savez."""
        return {"points": self.points.astype(np.float16), "tokens": self.tokens, "joints": self.joints,
                "category": np.array(self.category)}

    @staticmethod
    def from_arrays(data: dict[str, np.ndarray]) -> SkeletonSample:
        return SkeletonSample(data["points"].astype(np.float32), data["tokens"].astype(np.int64),
                              data["joints"].astype(np.float32), str(data["category"]))


def target_skeleton(character: Character) -> Skeleton:
    """The character's skin joints that influence vertices (or have a descendant that does): the eval's ground truth."""
    return used_skeleton(character.skeleton, used_joints(character.skeleton, character.weights))


def skeleton_class(character: Character, skeleton: Skeleton, tokenizer: SkeletonTokenizer) -> str:
    """The class token's name for a character's skeleton (see the module docstring)."""
    if tokenizer.templates(skeleton)[0]:
        return "mixamo"
    if character.name.startswith(creature_bodies.NAME_PREFIX):
        return "none"
    return "vroid" if character.name.startswith(GAME_ENGINE_PREFIX) else "articulation"


def upright_turned(character: Character, rng: np.random.Generator, degrees: float) -> Character:
    """The character turned about +Y by a random angle in ±degrees."""
    m = Rotation.from_euler("y", rng.uniform(-degrees, degrees), degrees=True).as_matrix()
    skeleton = Skeleton(character.skeleton.positions @ m.T, character.skeleton.parents, character.skeleton.names)
    return Character(character.name, character.category, character.vertices @ m.T, character.faces, skeleton, character.weights)


def make_skeleton_sample(character: Character, rng: np.random.Generator, points: int, tokenizer: SkeletonTokenizer) -> SkeletonSample:
    """Points, class and tokens of one (augmented) character."""
    skeleton = target_skeleton(character)
    cloud, norm = shape_points(character.vertices, character.faces, points, rng)
    tokens = tokenizer.encode(skeleton, norm, cls=skeleton_class(character, skeleton, tokenizer))
    joints = tokenizer.model_frame(norm.to_unit(skeleton.positions)).astype(np.float32)
    return SkeletonSample(cloud, tokens, joints, character.category)


def build_skeleton_data(config: SkeletonDataConfig, out: Path, report: Callable[[str, int, int], None],
                        workers: int = 1) -> dict:
    """Write out/train/*.npz and out/val/*.npz (on `workers` processes); report(name, done, total) after each
    character. Returns counts."""
    tokenizer = SkeletonTokenizer(max_length=config.max_tokens)
    skipped: dict[str, str] = {}

    def samples(characters: list[Character], rng: np.random.Generator) -> list[dict[str, np.ndarray]]:
        return [make_skeleton_sample(c, rng, config.points, tokenizer).arrays() for c in characters]

    def augmented(count: int) -> Make:
        return lambda c, rng: samples([upright_turned(v, rng, config.turn_degrees)
                                       for v in variants(c, rng, count, config.pose_degrees, turn=False)], rng)

    jobs, total = character_jobs(Path(config.corpus), config.seed, config.anny_bodies, skipped,
                                 train=augmented(config.variants), val=lambda c, rng: samples([normalised(c)], rng),
                                 body=augmented(config.anny_variants), creatures=config.creatures)
    return fill_cache(out, asdict(config), jobs, total, skipped, report, workers)
