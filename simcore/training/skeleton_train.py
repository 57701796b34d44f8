"""`rigforge train skeleton`: fit the skeleton-token model on cached samples, select on `val`, save safetensors.

Each step draws `batch` training samples (a sample's chance ∝ 1/√(its category's sample count), so humanoids
do not drown the rest) with a random `points` of each sample's surface points, and minimises the next-token
cross-entropy; a coordinate target is spread over its neighbouring bins (Gaussian, `coord_sigma` bins) so a
near miss costs less than a far one. Every `val_every` steps: the plain next-token loss (NLL per token) on all
`val` samples, the selection criterion; every `decode_every` steps also the J2J (unit-cube units) of greedy,
grammar-constrained decodes of the first `decode_val` val characters with their own class token. One JSON line
per log block and per validation goes to the log.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Collection
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import torch
from torch.nn import functional as F

from simcore.metrics.skeleton import chamfer
from simcore.model_weights import save_weights
from simcore.skeleton.grammar import SkeletonGrammar
from simcore.skeleton.learned_model import SLOT_AXES, SkeletonModelConfig, SkeletonTokenModel, sequence_slots
from simcore.skeleton.token_decoding import decode_tokens
from simcore.skeleton.tokenizer import Normalization, SkeletonTokenizer
from simcore.skeleton.vocab import CLASS_TOKENS, NUM_BINS, PAD, VOCAB_SIZE, dequantize, quantize
from simcore.training.sample_cache import sample_character
from simcore.training.skeleton_dataset import SkeletonSample


@dataclass(frozen=True)
class SkeletonTrainConfig:
    """The JSON config's "train" section."""

    steps: int = 4000
    batch: int = 8
    points: int = 1024
    lr: float = 1e-3
    weight_decay: float = 0.01
    coord_sigma: float = 1.0
    axis_scale: float = 0.0  # each step squashes a sample along x, y, z by factors from [1 - this, 1] (`full_scale`)
    val_every: int = 250
    decode_every: int = 1000
    decode_val: int = 6
    log_every: int = 50
    seed: int = 0
    threads: int = 2
    exclude: tuple[str, ...] = ()  # training characters left out (held-out families: skeleton_family_cv.py)
    model: SkeletonModelConfig = field(default_factory=SkeletonModelConfig)


@dataclass
class LoadedSample:
    """A cached sample as tensors, with the slot of each position's next token."""

    points: torch.Tensor
    tokens: torch.Tensor
    slots: torch.Tensor
    joints: np.ndarray
    category: str


def load_skeleton_samples(folder: Path, max_tokens: int, exclude: Collection[str] = ()) -> list[LoadedSample]:
    """Every .npz sample in `folder` whose sequence fits `max_tokens`, but those of the `exclude`d characters."""
    grammar = SkeletonGrammar(max_length=max_tokens)
    out = []
    for path in sorted(folder.glob("*.npz")):
        if sample_character(path) in exclude:
            continue
        with np.load(path, allow_pickle=False) as data:
            s = SkeletonSample.from_arrays(dict(data))
        if len(s.tokens) <= max_tokens:
            out.append(LoadedSample(torch.from_numpy(s.points), torch.from_numpy(s.tokens),
                                    torch.from_numpy(sequence_slots(s.tokens, grammar)), s.joints, s.category))
    return out


def soft_targets(sigma: float) -> torch.Tensor:
    """(267, 267) target distribution per target token: a Gaussian over bins for a coordinate, one-hot otherwise."""
    table = torch.eye(VOCAB_SIZE)
    if sigma > 0:
        bins = torch.arange(NUM_BINS, dtype=torch.float32)
        table[:NUM_BINS, :NUM_BINS] = torch.softmax(-0.5 * ((bins[:, None] - bins[None]) / sigma) ** 2, dim=1)
    return table


def token_axes(slots: torch.Tensor) -> torch.Tensor:
    """(L,) axis (0 x, 1 y, 2 z) of each token of a sequence whose next-token slots are `slots` (L,), for the
    coordinate tokens (anything for the others): token t's slot is slots[t - 1] (see learned_model.next_slot)."""
    own = torch.cat([torch.zeros(1, dtype=slots.dtype), slots[:-1]])
    return torch.from_numpy(SLOT_AXES)[own]


def squashed(sample: LoadedSample, factors: np.ndarray) -> tuple[torch.Tensor, torch.Tensor]:
    """(points, tokens) of `sample` scaled by `factors` (3,) along x, y, z about the token frame's centre:
    positions times the factors, normals by the inverse (then unit length), coordinate bins re-quantised."""
    f = torch.from_numpy(np.asarray(factors, np.float32))
    normals = sample.points[:, 3:] / f
    points = torch.cat([sample.points[:, :3] * f, normals / normals.norm(dim=1, keepdim=True).clamp_min(1e-9)], dim=1)
    coord = sample.tokens < NUM_BINS
    scale = f.double()[token_axes(sample.slots)]
    moved = torch.from_numpy(quantize(dequantize(sample.tokens.clamp(max=NUM_BINS - 1).numpy()) * scale.numpy()))
    return points, torch.where(coord, moved, sample.tokens)


def full_scale(factors: np.ndarray, points: torch.Tensor) -> np.ndarray:
    """`factors` (3,) rescaled so that the squashed points' longest extent equals the unsquashed one: inference
    normalises every mesh to span the token cube along its longest side, so a squashed sample must too."""
    extents = np.ptp(points[:, :3].numpy(), axis=0).astype(np.float64)
    squashed_longest = float((extents * factors).max())
    return factors * (float(extents.max()) / squashed_longest) if squashed_longest > 0 else factors


def batch_tensors(samples: list[LoadedSample], points: int, rng: np.random.Generator | None,
                  axis_scale: float = 0.0) -> tuple[torch.Tensor, ...]:
    """points (B, N, 6), inputs (B, L-1), slots (B, L-1), targets (B, L-1) padded with <pad>; a random `points`
    of each sample's points with `rng`, the first ones without; with `rng` and `axis_scale`, each sample squashed
    along each axis by a random factor in [1 - axis_scale, 1], then scaled back to its longest extent (`squashed`,
    `full_scale`)."""
    length = max(len(s.tokens) for s in samples)
    cloud, inputs, slots, targets = [], [], [], []
    for s in samples:
        n = len(s.points)
        rows = torch.from_numpy(rng.choice(n, size=min(points, n), replace=False)) if rng is not None else torch.arange(min(points, n))
        pts, tokens = s.points, s.tokens
        if rng is not None and axis_scale > 0:
            pts, tokens = squashed(s, full_scale(rng.uniform(1.0 - axis_scale, 1.0, 3), s.points))
        cloud.append(pts[rows])
        padded = F.pad(tokens, (0, length - len(tokens)), value=PAD)
        inputs.append(padded[:-1])
        targets.append(padded[1:])
        slots.append(F.pad(s.slots, (0, length - len(s.slots)))[:-1])
    return torch.stack(cloud), torch.stack(inputs), torch.stack(slots), torch.stack(targets)


def batch_loss(model: SkeletonTokenModel, batch: tuple[torch.Tensor, ...], table: torch.Tensor) -> torch.Tensor:
    """Mean cross-entropy against the soft targets over the non-pad targets."""
    cloud, inputs, slots, targets = batch
    logp = torch.log_softmax(model(cloud, inputs, slots), dim=-1)
    keep = targets != PAD
    return -(table[targets[keep]] * logp[keep]).sum(dim=-1).mean()


def val_nll(model: SkeletonTokenModel, val: list[LoadedSample], points: int) -> float:
    """Mean next-token NLL per token over the val samples (hard targets, no gradient)."""
    model.eval()
    total, count = 0.0, 0
    with torch.no_grad():
        for k in range(0, len(val), 8):
            cloud, inputs, slots, targets = batch_tensors(val[k:k + 8], points, None)
            logp = torch.log_softmax(model(cloud, inputs, slots), dim=-1)
            keep = targets != PAD
            total += float(-logp[keep].gather(1, targets[keep][:, None]).sum())
            count += int(keep.sum())
    model.train()
    return round(total / count, 5)


def val_j2j(model: SkeletonTokenModel, val: list[LoadedSample], points: int, count: int) -> float:
    """Mean J2J (unit-cube units) of greedy decodes of the first `count` val samples, each with its own class."""
    model.eval()
    tokenizer = SkeletonTokenizer(max_length=model.config.max_tokens)
    grammar = SkeletonGrammar(max_length=model.config.max_tokens)
    classes = {v: k for k, v in CLASS_TOKENS.items()}
    unit = Normalization(np.zeros(3), 1.0)
    scores = []
    for s in val[:count]:
        tokens, _ = decode_tokens(model, s.points[:points], [classes[int(s.tokens[1])]], grammar)[0]
        joints = tokenizer.model_frame(tokenizer.decode(tokens, unit).positions)
        scores.append(chamfer(joints, s.joints) / 2.0)  # token cube side 2 → unit cube side 1
    model.train()
    return round(float(np.mean(scores)), 5)


def train_skeleton(config: SkeletonTrainConfig, data: Path, out: Path, log: Path, report: Callable[[int, int, dict], None]) -> dict:
    """Train on data/train, select on data/val NLL, save the best model to `out` (.safetensors). Returns the summary."""
    torch.manual_seed(config.seed)
    torch.set_num_threads(config.threads)
    rng = np.random.default_rng(config.seed)
    train = load_skeleton_samples(data / "train", config.model.max_tokens, set(config.exclude))
    val = load_skeleton_samples(data / "val", config.model.max_tokens)
    if not train or not val:
        raise FileNotFoundError(f"no training or validation samples under {data}: run `rigforge train skeleton-data` first")
    cats = [s.category for s in train]
    counts = {c: cats.count(c) for c in sorted(set(cats))}
    kinds = [SkeletonTokenizer.read_class(s.tokens.numpy()) for s in train]
    classes = {c: kinds.count(c) for c in sorted(set(kinds))}  # inference decodes each class the model learned
    chance = np.array([1.0 / np.sqrt(counts[c]) for c in cats])
    chance /= chance.sum()
    model = SkeletonTokenModel(config.model)
    table = soft_targets(config.coord_sigma)
    opt = torch.optim.AdamW(model.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=config.lr, total_steps=config.steps, pct_start=0.05)
    started = time.perf_counter()
    best = {"nll": val_nll(model, val, config.points)}
    start_val = dict(best)
    best_state = {k: v.clone() for k, v in model.state_dict().items()}
    best_step, running = 0, []
    with log.open("w", encoding="utf-8") as fh:
        fh.write(json.dumps({"event": "start", "train_samples": len(train), "val_samples": len(val), "categories": counts,
                             "classes": classes,
                             "parameters": sum(p.numel() for p in model.parameters()), "config": asdict(config),
                             "val": best}) + "\n")
        for step in range(1, config.steps + 1):
            picked = [train[i] for i in rng.choice(len(train), size=config.batch, p=chance)]
            loss = batch_loss(model, batch_tensors(picked, config.points, rng, config.axis_scale), table)
            opt.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
            opt.step()
            sched.step()
            running.append(loss.item())
            entry: dict = {}
            if step % config.log_every == 0:
                entry = {"step": step, "seconds": round(time.perf_counter() - started, 1), "lr": sched.get_last_lr()[0],
                         "loss": round(float(np.mean(running)), 5)}
                running = []
            if step % config.val_every == 0 or step == config.steps:
                scores = {"nll": val_nll(model, val, config.points)}
                if step % config.decode_every == 0 or step == config.steps:
                    scores["j2j"] = val_j2j(model, val, config.points, config.decode_val)
                entry.update(step=step, val=scores)
                if scores["nll"] < best["nll"]:
                    best, best_step = scores, step
                    best_state = {k: v.clone() for k, v in model.state_dict().items()}
            if entry:
                fh.write(json.dumps(entry) + "\n")
                fh.flush()
                report(step, config.steps, entry)
    model.load_state_dict(best_state)
    if "j2j" not in best:
        best["j2j"] = val_j2j(model, val, config.points, config.decode_val)
    summary = {"best_step": best_step, "val": best, "val_at_start": start_val, "seconds": round(time.perf_counter() - started, 1),
               "train_samples": len(train), "val_samples": len(val), "categories": counts, "classes": classes,
               "config": asdict(config)}
    save_weights(model, out, summary)
    with log.open("a", encoding="utf-8") as fh:
        fh.write(json.dumps({"event": "end", **summary}) + "\n")
    return summary
