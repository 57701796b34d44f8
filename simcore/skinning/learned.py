"""The `learned` skinning method: the trained bone–point attention model (weights shipped in the repo).

The model is read once per process (a worker loads it on its first job, never per job). It is an ensemble
(ensemble.py): a member trained on every corpus train family and one per group of families left out, stored best
first by their own val L1, whose logits are averaged. Each character is read by as many of the first members as
PASS_PAIRS allows, and twice, as it is and turned half a turn about the up axis, when every member fits twice
(TURNS); the two readings' weights are averaged. Its file is a safetensors state dict whose metadata carries the
network sizes and training summary; a missing or corrupt file raises ModelUnavailable with the path and the reason.

The model's weights are then multiplied by the geodesic prior's (the falloff over the same candidate joints that
the model also reads as a feature), each raised to its share, and the rows renormalised: a product of experts with
PRIOR_SHARE for the prior. Where the model hesitates between joints the prior's distance through the solid
decides, and where the prior spreads a vertex over several joints the model's sharper choice stays. The share is
chosen by held-out source family (`rigforge train skin-cv`; README, Skinning); 0 gives the model's own weights.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import torch

from simcore.model_weights import cached_per_file, load_weights, read_metadata
from simcore.skeleton.types import JointKind, Skeleton
from simcore.skinning.attention_model import ModelConfig, SkinAttention
from simcore.skinning.ensemble import SkinEnsemble
from simcore.skinning.pair_features import skin_inputs, turned

WEIGHTS = Path(__file__).parent / "weights" / "skin_attention.safetensors"
CHUNK = 1024  # vertices per forward pass: the (chunk, K, width) activations stay in the CPU cache
# Test-time augmentation: the model also reads the character turned half a turn about the up axis, and the two
# predictions are averaged (it was trained on random turns, and its output still varies with the turn).
TURNS = (0.0, np.pi)
# Network passes (one member reading the character once) times vertex-candidate pairs, per character: more members
# first, then the second turn. A 50k-vertex, 60-joint character (~850k pairs) gets one pass of the first member, as
# the ≤ 3 s skinning target needs (a pass of the network costs about 0.6 µs a pair on one CPU core); a 6k-vertex
# character gets every member twice.
PASS_PAIRS = 1_280_000
PROGRESS_EVERY = 16  # chunks between progress reports
PRIOR_SHARE = 0.15  # the geodesic prior's exponent in the product with the model's weights (module doc)
ARMATURE_ROOT = "__armature_root__"


@dataclass(frozen=True)
class LearnedSkinning:
    """What the learned method runs: the model's weights file and the geodesic prior's share (PRIOR_SHARE)."""

    model: Path = WEIGHTS
    prior_share: float = PRIOR_SHARE

    def overridden(self, model: Path | None = None, prior_share: float | None = None) -> LearnedSkinning:
        """This choice with `model` and `prior_share` replaced where given (a command's options)."""
        return replace(self, model=self.model if model is None else model,
                       prior_share=self.prior_share if prior_share is None else prior_share)


SHIPPED = LearnedSkinning()  # the learned method as jobs run it: the model file in the repo and PRIOR_SHARE


def with_prior(weights: np.ndarray, prior: np.ndarray, share: float) -> np.ndarray:
    """(V, K) rows ∝ weights^(1 − share) · exp(prior)^share, summing to 1: the model's weights over the candidates
    times the geodesic prior's (`prior`: its log-weights), each to its share; `share` 0 returns `weights`."""
    if share <= 0.0:
        return weights
    log = (1.0 - share) * np.log(np.maximum(weights, 1e-12)) + share * prior
    out = np.exp(log - log.max(axis=1, keepdims=True))
    return out / out.sum(axis=1, keepdims=True)


def learned_summary(learned: LearnedSkinning = SHIPPED) -> str:
    """One line for reports: why `auto` takes the learned model (its val figures beside the geodesic prior's) and
    the prior's share in what it runs."""
    summary = read_metadata(learned.model, "skinning", "skinning")["summary"]
    val, start = summary["val"], summary["val_at_start"]
    members = len(summary.get("members", [])) or 1
    return (f"learned model{f' (ensemble of {members})' if members > 1 else ''}: corpus val L1 {val['l1']:.3f} vs "
            f"{start['l1']:.3f} for the geodesic prior it refines, "
            f"deformation {val['deform']:.4f} vs {start['deform']:.4f}; its weights times the prior's to the share "
            f"{learned.prior_share:g}")


@cached_per_file(maxsize=4)
def load_model(path: Path = WEIGHTS) -> SkinEnsemble:
    """The model stored at `path` as an ensemble (a file of one plain model: an ensemble of one), in eval mode
    (read once per process, again if the file changes)."""
    model = load_weights(path, "skinning", "skinning", SkinEnsemble.of_size)
    return model if isinstance(model, SkinEnsemble) else SkinEnsemble([model]).eval()


def load_member(path: Path) -> SkinAttention:
    """The plain model stored at `path` (what `rigforge train skin` writes for one model), in eval mode."""
    return load_weights(path, "skinning", "skinning", lambda sizes: SkinAttention(ModelConfig(**sizes)))


def with_armature_root(vertices: np.ndarray, skeleton: Skeleton) -> Skeleton:
    """`skeleton` under one more root, below its root at the mesh's lowest height: the unweighted armature root
    most artist rigs (the model's training data) carry, whose child is the body's own centre joint."""
    below = skeleton.positions[0].copy()
    below[1] = float(vertices[:, 1].min())
    return skeleton.under_root(below, ARMATURE_ROOT, JointKind.FREE)


def learned_weights(
    vertices: np.ndarray, faces: np.ndarray, skeleton: Skeleton, *, learned: LearnedSkinning = SHIPPED,
    progress: Callable[[float], None] = lambda fraction: None, root_deforms: bool = False,
) -> np.ndarray:
    """(V, J) float64 weights, rows summing to 1, predicted by `learned.model` and multiplied by the geodesic
    prior to `learned.prior_share` (see the module doc).

    root_deforms: the skeleton's root is a body joint that bends the mesh (our predicted skeletons) rather than
    an armature root; the model, which learned that artists leave the armature root unweighted, is then given
    one above it (`with_armature_root`) and its column is dropped.
    """
    if root_deforms:
        out = learned_weights(vertices, faces, with_armature_root(vertices, skeleton), learned=learned,
                              progress=progress)[:, 1:]
        out[out.sum(axis=1) <= 0, 0] = 1.0  # a vertex the model gave wholly to the armature root: the body's root
        return out / out.sum(axis=1, keepdims=True)
    inputs = skin_inputs(vertices, faces, skeleton, progress=lambda f: progress(0.7 * f))
    pairs = max(inputs.candidates.size, 1)
    model = load_model(learned.model).leading(PASS_PAIRS // pairs)
    turns = TURNS if pairs * len(model.members) * len(TURNS) <= PASS_PAIRS else TURNS[:1]
    count = len(inputs.candidates)
    mean = np.zeros(inputs.candidates.shape)  # (V, K) over the candidates, which no turn changes
    for k, angle in enumerate(turns):
        seen = turned(inputs, angle) if angle else inputs
        with torch.no_grad():
            bones = model.bones(torch.from_numpy(seen.bone))
            for start in range(0, count, CHUNK):
                rows = slice(start, start + CHUNK)
                logits = model.logits(torch.from_numpy(seen.pair[rows]), bones, torch.from_numpy(seen.point[rows]),
                                      torch.from_numpy(seen.candidates[rows]), torch.from_numpy(seen.prior[rows]))
                mean[rows] += torch.softmax(logits, dim=-1).double().numpy() / len(turns)
                if (start // CHUNK) % PROGRESS_EVERY == 0:
                    progress(0.7 + 0.3 * min(1.0, (k * count + start + CHUNK) / (len(turns) * count)))
    out = np.zeros((count, skeleton.num_joints))
    np.put_along_axis(out, inputs.candidates, with_prior(mean, inputs.prior.astype(np.float64), learned.prior_share), axis=1)
    progress(1.0)
    return out
