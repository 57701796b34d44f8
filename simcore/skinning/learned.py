"""The `learned` skinning method: the trained bone–point attention model (weights shipped in the repo).

The model is read once per process (a worker loads it on its first job, never per job). Its file is a
safetensors state dict whose metadata carries the network sizes and training summary; a missing or corrupt
file raises ModelUnavailable with the path and the reason.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from functools import lru_cache
from pathlib import Path

import numpy as np
import torch
from safetensors import SafetensorError, safe_open
from safetensors.torch import load_file, save_file

from simcore.errors import SimcoreError
from simcore.skeleton.types import Skeleton
from simcore.skinning.attention_model import ModelConfig, SkinAttention
from simcore.skinning.pair_features import skin_inputs

WEIGHTS = Path(__file__).parent / "weights" / "skin_attention.safetensors"
CHUNK = 8192  # vertices per forward pass: bounds the (chunk, K, width) activations


class ModelUnavailable(SimcoreError):
    """A learned model's weights cannot be read (`field`: the stage whose model it is)."""

    def __init__(self, message: str, field: str = "skinning"):
        super().__init__(message, code="model_unavailable", field=field)


def save_model(model: SkinAttention, path: Path, summary: dict) -> None:
    """Write the state dict as safetensors with the network sizes and `summary` as JSON metadata."""
    path.parent.mkdir(parents=True, exist_ok=True)
    state = {k: v.detach().contiguous() for k, v in model.state_dict().items()}
    save_file(state, str(path), metadata={"model": json.dumps(model.config.to_dict()), "summary": json.dumps(summary)})


@lru_cache(maxsize=4)
def read_metadata(path: Path = WEIGHTS) -> dict[str, dict]:
    """The file's JSON metadata: "model" (network sizes) and "summary" (training and val figures)."""
    if not path.is_file():
        raise ModelUnavailable(f"learned skinning weights not found at {path}")
    try:
        with safe_open(str(path), framework="pt") as fh:
            meta = fh.metadata() or {}
        return {key: json.loads(meta[key]) for key in ("model", "summary")}
    except (SafetensorError, OSError, KeyError, ValueError) as exc:
        raise ModelUnavailable(f"learned skinning weights at {path} are unreadable: {type(exc).__name__}: {exc}"[:300]) from exc


def learned_summary(path: Path = WEIGHTS) -> str:
    """One line for reports: why `auto` takes the learned model (its val figures beside the geodesic prior's)."""
    summary = read_metadata(path)["summary"]
    val, start = summary["val"], summary["val_at_start"]
    return (f"learned model: corpus val L1 {val['l1']:.3f} vs {start['l1']:.3f} for the geodesic prior it refines, "
            f"deformation {val['deform']:.4f} vs {start['deform']:.4f}")


@lru_cache(maxsize=4)
def load_model(path: Path = WEIGHTS) -> SkinAttention:
    """The model stored at `path`, in eval mode (cached per process)."""
    sizes = read_metadata(path)["model"]
    try:
        model = SkinAttention(ModelConfig(**sizes))
        model.load_state_dict(load_file(str(path)))
    except (SafetensorError, OSError, RuntimeError, TypeError) as exc:
        raise ModelUnavailable(f"learned skinning weights at {path} do not fit the model: {type(exc).__name__}: {exc}"[:300]) from exc
    model.eval()
    return model


def learned_weights(
    vertices: np.ndarray, faces: np.ndarray, skeleton: Skeleton, *, model_path: Path = WEIGHTS,
    progress: Callable[[float], None] = lambda fraction: None,
) -> np.ndarray:
    """(V, J) float64 weights, rows summing to 1, predicted by the learned model."""
    model = load_model(model_path)
    inputs = skin_inputs(vertices, faces, skeleton, progress=lambda f: progress(0.7 * f))
    out = np.zeros((len(inputs.candidates), skeleton.num_joints))
    with torch.no_grad():
        bones = model.bones(torch.from_numpy(inputs.bone))
        for start in range(0, len(out), CHUNK):
            rows = slice(start, start + CHUNK)
            cand = torch.from_numpy(inputs.candidates[rows])
            logits = model.logits(torch.from_numpy(inputs.pair[rows]), bones, torch.from_numpy(inputs.point[rows]), cand,
                                  torch.from_numpy(inputs.prior[rows]))
            np.put_along_axis(out[rows], inputs.candidates[rows], torch.softmax(logits, dim=-1).double().numpy(), axis=1)
            progress(0.7 + 0.3 * min(1.0, (start + CHUNK) / len(out)))
    return out
