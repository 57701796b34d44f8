"""`rigforge train skin`: fit the bone–point attention model on cached samples, select on `val`, save safetensors.

Each step draws `batch` training samples (categories re-weighted: a sample's chance ∝ 1/√(its category's
sample count), so humanoids do not drown the rest) and `points` vertices of each. Loss per vertex: L1 between
predicted and artist weights (mass outside the candidates counts as error), `kl` × cross-entropy, and
`deform` × the distance between the vertex skinned with predicted and with artist weights in random poses
(unit-cube units). Every `val_every` steps the model is scored on all `val` samples (mean L1 and deformation);
the best state by val L1 is what gets saved (with `ema`, the moving average of the weights is what is scored
and saved). One JSON line per step block and per validation goes to the log.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Collection
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any, cast

import numpy as np
import torch
from torch.optim.swa_utils import AveragedModel, get_ema_multi_avg_fn

from simcore.model_weights import save_weights
from simcore.skinning.attention_model import ModelConfig, SkinAttention
from simcore.training.fold_pool import step_reporter
from simcore.training.sample_cache import sample_character
from simcore.training.skin_samples import SkinSample


@dataclass(frozen=True)
class TrainConfig:
    """The JSON config's "train" section."""

    steps: int = 6000
    batch: int = 4
    points: int = 1024
    lr: float = 2e-3
    weight_decay: float = 1e-4
    kl: float = 0.2
    deform: float = 20.0
    val_every: int = 250
    log_every: int = 50
    seed: int = 0
    threads: int = 1  # per-sample ops are small: extra intra-op threads spin and wait when another process holds a core
    device: str = "cpu"  # "cuda" trains on the GPU (samples are moved there once)
    forward_samples: int = 1  # samples per forward pass (0: the whole batch); one at a time keeps a CPU's cache warm
    ema: float = 0.0  # > 0: validate and save an exponential moving average of the weights with this decay per step
    exclude: tuple[str, ...] = ()  # training characters left out (held-out families: skin_family_cv.py)
    model: ModelConfig = field(default_factory=ModelConfig)


Tensors = dict[str, torch.Tensor]


def sample_tensors(s: SkinSample, device: str = "cpu") -> Tensors:
    """One sample's inputs and targets as tensors on `device`."""
    i = s.inputs
    arrays = {"pair": i.pair, "bone": i.bone, "point": i.point, "candidates": i.candidates, "prior": i.prior,
              "target": s.target, "outside": s.outside, "moved": s.moved, "posed": s.posed}
    return {k: torch.from_numpy(v).to(device) for k, v in arrays.items()}


def load_samples(folder: Path, device: str = "cpu", exclude: Collection[str] = ()) -> tuple[list[Tensors], list[str]]:
    """Every .npz sample in `folder` as tensors on `device`, with its category; samples of `exclude`d characters
    are left out."""
    out, cats = [], []
    for path in sorted(folder.glob("*.npz")):
        if sample_character(path) in exclude:
            continue
        with np.load(path, allow_pickle=False) as data:
            s = SkinSample.from_arrays(dict(data))
        out.append(sample_tensors(s, device))
        cats.append(s.category)
    return out, cats


def _rows(sample: Tensors, rows: torch.Tensor | None) -> Tensors:
    if rows is None:
        return sample
    out = {k: v[rows] for k, v in sample.items() if k not in ("bone", "moved", "posed")}
    out.update(bone=sample["bone"], moved=sample["moved"][:, rows], posed=sample["posed"][:, rows])
    return out


def _padded(tensors: list[torch.Tensor], width: int, dim: int = 1) -> torch.Tensor:
    """Concatenate along the vertex axis after zero-padding the candidate axis `dim` to `width`."""
    out = []
    for t in tensors:
        pad = [0, 0] * (t.dim() - dim - 1) + [0, width - t.shape[dim]]
        out.append(torch.nn.functional.pad(t, pad))
    return torch.cat(out, dim=dim - 1)


def batch_losses(model: SkinAttention, samples: list[Tensors]) -> dict[str, torch.Tensor]:
    """Mean over `samples` of each one's mean L1, cross-entropy and deformation, in one forward pass: bone sets
    are padded and masked in the bone context, every sample's rows are read against the flat stack of bone
    embeddings (candidates offset per sample, padded to the widest candidate list and masked out of the
    softmax), so a step costs the same kernels for 1 or 32 samples."""
    device = samples[0]["bone"].device
    counts = torch.tensor([len(s["bone"]) for s in samples], device=device)
    bone = torch.nn.utils.rnn.pad_sequence([s["bone"] for s in samples], batch_first=True)
    padding = torch.arange(bone.shape[1], device=device)[None] >= counts[:, None]
    bones = model.bone_context(model.bone_in(bone), src_key_padding_mask=padding)[~padding]  # (ΣJ, width)
    offsets = torch.cumsum(counts, 0) - counts
    width = max(s["candidates"].shape[1] for s in samples)
    rows = torch.tensor([len(s["target"]) for s in samples], device=device)
    candidates = _padded([s["candidates"] + o for s, o in zip(samples, offsets)], width)
    valid = _padded([torch.ones_like(s["candidates"], dtype=torch.bool) for s in samples], width)
    pair, prior, target = (_padded([s[k] for s in samples], width) for k in ("pair", "prior", "target"))
    point, outside = (torch.cat([s[k] for s in samples]) for k in ("point", "outside"))
    p = torch.softmax(model.logits(pair, bones, point, candidates, prior, valid), dim=-1)
    moved = _padded([s["moved"] for s in samples], width, dim=2)
    posed = torch.cat([s["posed"] for s in samples], dim=1)
    per_row = row_losses(p, target, outside, moved, posed)
    owner = torch.repeat_interleave(torch.arange(len(samples), device=device), rows)
    return {k: (torch.zeros(len(samples), device=device).index_add(0, owner, v) / rows).mean() for k, v in per_row.items()}


def row_losses(p: torch.Tensor, target: torch.Tensor, outside: torch.Tensor, moved: torch.Tensor, posed: torch.Tensor
               ) -> dict[str, torch.Tensor]:
    """Per vertex: L1 to the artist's row (`outside`: artist mass on no candidate), cross-entropy, and the distance
    between the vertex skinned with `p` (V, K) and with the artist's weights in each pose (`moved` (P, V, K, 3): each
    candidate's transform applied to the vertex; `posed` (P, V, 3)), averaged over the poses."""
    return {
        "l1": (p - target).abs().sum(dim=1) + outside,
        "ce": -(target * torch.log(p + 1e-8)).sum(dim=1),
        "deform": ((p[None, :, :, None] * moved).sum(dim=2) - posed).norm(dim=-1).mean(dim=0),
    }


def evaluate(model: torch.nn.Module, samples: list[Tensors]) -> dict[str, float]:
    """Mean L1 and deformation over whole samples (no gradient) of a model whose forward maps (pair, bone, point,
    candidates, prior) to weights over the candidates (SkinAttention or SkinEnsemble)."""
    was_training = model.training
    model.eval()
    with torch.no_grad():
        parts = []
        for s in samples:
            p = model(s["pair"], s["bone"], s["point"], s["candidates"], s["prior"])
            parts.append({k: v.mean() for k, v in row_losses(p, s["target"], s["outside"], s["moved"], s["posed"]).items()})
    model.train(was_training)
    return {k: round(float(np.mean([float(p[k]) for p in parts])), 5) for k in ("l1", "deform")}


def train_skin(config: TrainConfig, data: Path, out: Path, log: Path, report: Callable[[int, int, dict], None]) -> dict:
    """Train on data/train, select on data/val, save the best model to `out` (.safetensors + .json). Returns the summary."""
    torch.manual_seed(config.seed)
    torch.set_num_threads(config.threads)
    rng = np.random.default_rng(config.seed)
    train, cats = load_samples(data / "train", config.device, set(config.exclude))
    val, _ = load_samples(data / "val", config.device)
    if not train or not val:
        raise FileNotFoundError(f"no training or validation samples under {data}: run `rigforge train data` first")
    counts = {c: cats.count(c) for c in set(cats)}
    chance = np.array([1.0 / np.sqrt(counts[c]) for c in cats])
    chance /= chance.sum()
    model = SkinAttention(config.model).to(config.device)
    opt = torch.optim.AdamW(model.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=config.lr, total_steps=config.steps, pct_start=0.05)
    averaged = AveragedModel(model, multi_avg_fn=get_ema_multi_avg_fn(config.ema)) if config.ema > 0 else None
    scored = cast(SkinAttention, averaged.module) if averaged is not None else model
    started = time.perf_counter()
    best = evaluate(model, val)
    best_state = {k: v.clone() for k, v in model.state_dict().items()}
    best_step = 0
    history = [{"step": 0, "val": best}]
    running: dict[str, list[torch.Tensor]] = {"loss": [], "l1": [], "ce": [], "deform": []}  # read at log time: no sync per step
    with log.open("w", encoding="utf-8") as fh:
        fh.write(json.dumps({"event": "start", "train_samples": len(train), "val_samples": len(val), "categories": counts,
                             "config": asdict(config), "val": best}) + "\n")
        for step in range(1, config.steps + 1):
            picked = []
            for index in rng.choice(len(train), size=config.batch, p=chance):
                s = train[index]
                n = len(s["target"])
                rows = torch.from_numpy(rng.choice(n, size=config.points, replace=False)).to(config.device) if n > config.points else None
                picked.append(_rows(s, rows))
            group = config.forward_samples or len(picked)
            step_parts = {k: torch.zeros((), device=config.device) for k in ("l1", "ce", "deform")}
            for start in range(0, len(picked), group):
                chunk = picked[start:start + group]
                for k, v in batch_losses(model, chunk).items():
                    step_parts[k] = step_parts[k] + v * len(chunk) / len(picked)  # the batch mean, whatever the chunks
            loss = step_parts["l1"] + config.kl * step_parts["ce"] + config.deform * step_parts["deform"]
            for k, v in step_parts.items():
                running[k].append(v.detach())
            opt.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
            opt.step()
            sched.step()
            if averaged is not None:
                averaged.update_parameters(model)
            running["loss"].append(loss.detach())
            entry: dict = {}
            if step % config.log_every == 0:
                entry = {"step": step, "seconds": round(time.perf_counter() - started, 1), "lr": sched.get_last_lr()[0],
                         **{k: round(float(torch.stack(v).mean()), 5) for k, v in running.items()}}
                running = {k: [] for k in running}
            if step % config.val_every == 0 or step == config.steps:
                scores = evaluate(scored, val)
                entry.update(step=step, val=scores)
                history.append({"step": step, "val": scores})
                if scores["l1"] < best["l1"]:
                    best, best_step = scores, step
                    best_state = {k: v.clone() for k, v in scored.state_dict().items()}
            if entry:
                fh.write(json.dumps(entry) + "\n")
                fh.flush()
                report(step, config.steps, entry)
    model.load_state_dict(best_state)
    model.cpu()
    summary = {"best_step": best_step, "val": best, "val_at_start": history[0]["val"], "seconds": round(time.perf_counter() - started, 1),
               "train_samples": len(train), "val_samples": len(val), "categories": counts, "config": asdict(config)}
    save_weights(model, out, summary)
    with log.open("a", encoding="utf-8") as fh:
        fh.write(json.dumps({"event": "end", **summary}) + "\n")
    return summary


def train_without(index: int, progress: Any, held_out: Collection[str], steps: int, config: TrainConfig, cache: Path,
                  weights: Path) -> dict:
    """`train_skin` for `steps` steps without the characters `held_out` (a group of families), into `weights` and its
    .jsonl log beside it, putting (index, step) on the `progress` queue (fold_pool.run_folds). Returns its summary."""
    weights.parent.mkdir(parents=True, exist_ok=True)
    return train_skin(replace(config, exclude=tuple(held_out), steps=steps), cache, weights, weights.with_suffix(".jsonl"),
                      step_reporter(index, progress))
