"""`rigforge train skin`: fit the bone–point attention model on cached samples, select on `val`, save safetensors.

Each step draws `batch` training samples (categories re-weighted: a sample's chance ∝ 1/√(its category's
sample count), so humanoids do not drown the rest) and `points` vertices of each. Loss per vertex: L1 between
predicted and artist weights (mass outside the candidates counts as error), `kl` × cross-entropy, and
`deform` × the distance between the vertex skinned with predicted and with artist weights in random poses
(unit-cube units). Every `val_every` steps the model is scored on all `val` samples (mean L1 and deformation);
the best state by val L1 is what gets saved. One JSON line per step block and per validation goes to the log.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import torch

from simcore.model_weights import save_weights
from simcore.skinning.attention_model import ModelConfig, SkinAttention
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
    model: ModelConfig = field(default_factory=ModelConfig)


Tensors = dict[str, torch.Tensor]


def load_samples(folder: Path) -> tuple[list[Tensors], list[str]]:
    """Every .npz sample in `folder` as tensors, with its category."""
    out, cats = [], []
    for path in sorted(folder.glob("*.npz")):
        with np.load(path, allow_pickle=False) as data:
            s = SkinSample.from_arrays(dict(data))
        i = s.inputs
        out.append({"pair": torch.from_numpy(i.pair), "bone": torch.from_numpy(i.bone), "point": torch.from_numpy(i.point),
                    "candidates": torch.from_numpy(i.candidates), "prior": torch.from_numpy(i.prior),
                    "target": torch.from_numpy(s.target), "outside": torch.from_numpy(s.outside),
                    "moved": torch.from_numpy(s.moved), "posed": torch.from_numpy(s.posed)})
        cats.append(s.category)
    return out, cats


def _rows(sample: Tensors, rows: torch.Tensor | None) -> Tensors:
    if rows is None:
        return sample
    out = {k: v[rows] for k, v in sample.items() if k not in ("bone", "moved", "posed")}
    out.update(bone=sample["bone"], moved=sample["moved"][:, rows], posed=sample["posed"][:, rows])
    return out


def sample_losses(model: SkinAttention, s: Tensors) -> dict[str, torch.Tensor]:
    """Mean L1, cross-entropy and deformation of one sample's rows."""
    p = model(s["pair"], s["bone"], s["point"], s["candidates"], s["prior"])
    l1 = ((p - s["target"]).abs().sum(dim=1) + s["outside"]).mean()
    ce = -(s["target"] * torch.log(p + 1e-8)).sum(dim=1).mean()
    skinned = (p[None, :, :, None] * s["moved"]).sum(dim=2)
    deform = (skinned - s["posed"]).norm(dim=-1).mean()
    return {"l1": l1, "ce": ce, "deform": deform}


def evaluate(model: SkinAttention, samples: list[Tensors]) -> dict[str, float]:
    """Mean L1 and deformation over whole samples (no gradient)."""
    model.eval()
    with torch.no_grad():
        parts = [sample_losses(model, s) for s in samples]
    model.train()
    return {k: round(float(np.mean([float(p[k]) for p in parts])), 5) for k in ("l1", "deform")}


def train_skin(config: TrainConfig, data: Path, out: Path, log: Path, report: Callable[[int, int, dict], None]) -> dict:
    """Train on data/train, select on data/val, save the best model to `out` (.safetensors + .json). Returns the summary."""
    torch.manual_seed(config.seed)
    torch.set_num_threads(config.threads)
    rng = np.random.default_rng(config.seed)
    train, cats = load_samples(data / "train")
    val, _ = load_samples(data / "val")
    if not train or not val:
        raise FileNotFoundError(f"no training or validation samples under {data}: run `rigforge train data` first")
    counts = {c: cats.count(c) for c in set(cats)}
    chance = np.array([1.0 / np.sqrt(counts[c]) for c in cats])
    chance /= chance.sum()
    model = SkinAttention(config.model)
    opt = torch.optim.AdamW(model.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=config.lr, total_steps=config.steps, pct_start=0.05)
    started = time.perf_counter()
    best = evaluate(model, val)
    best_state = {k: v.clone() for k, v in model.state_dict().items()}
    best_step = 0
    history = [{"step": 0, "val": best}]
    running: dict[str, list[float]] = {"loss": [], "l1": [], "ce": [], "deform": []}
    with log.open("w", encoding="utf-8") as fh:
        fh.write(json.dumps({"event": "start", "train_samples": len(train), "val_samples": len(val), "categories": counts,
                             "config": asdict(config), "val": best}) + "\n")
        for step in range(1, config.steps + 1):
            loss = torch.zeros(())
            for index in rng.choice(len(train), size=config.batch, p=chance):
                s = train[index]
                n = len(s["target"])
                rows = torch.from_numpy(rng.choice(n, size=config.points, replace=False)) if n > config.points else None
                parts = sample_losses(model, _rows(s, rows))
                total = parts["l1"] + config.kl * parts["ce"] + config.deform * parts["deform"]
                loss = loss + total / config.batch
                for k in ("l1", "ce", "deform"):
                    running[k].append(parts[k].item())
            opt.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
            opt.step()
            sched.step()
            running["loss"].append(loss.item())
            entry: dict = {}
            if step % config.log_every == 0:
                entry = {"step": step, "seconds": round(time.perf_counter() - started, 1), "lr": sched.get_last_lr()[0],
                         **{k: round(float(np.mean(v)), 5) for k, v in running.items()}}
                running = {k: [] for k in running}
            if step % config.val_every == 0 or step == config.steps:
                scores = evaluate(model, val)
                entry.update(step=step, val=scores)
                history.append({"step": step, "val": scores})
                if scores["l1"] < best["l1"]:
                    best, best_step = scores, step
                    best_state = {k: v.clone() for k, v in model.state_dict().items()}
            if entry:
                fh.write(json.dumps(entry) + "\n")
                fh.flush()
                report(step, config.steps, entry)
    model.load_state_dict(best_state)
    summary = {"best_step": best_step, "val": best, "val_at_start": history[0]["val"], "seconds": round(time.perf_counter() - started, 1),
               "train_samples": len(train), "val_samples": len(val), "categories": counts, "config": asdict(config)}
    save_weights(model, out, summary)
    with log.open("a", encoding="utf-8") as fh:
        fh.write(json.dumps({"event": "end", **summary}) + "\n")
    return summary
