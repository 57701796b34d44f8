"""`rigforge train data|skin|skeleton-data|skeleton --config CONFIG`: build a learned model's samples, then train it.

CONFIG is a JSON file (simcore/training/configs/skin_cpu.json and skeleton_cpu.json are the shipped models'):
"cache" (sample folder), "out" (.safetensors), "log" (JSON lines), "data" and "train" sections (DataConfig and
TrainConfig for the skinning model, SkeletonDataConfig and SkeletonTrainConfig for the skeleton model). Needs the
`train` extra (`pip install -e '.[train]'`) for the anny bodies.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, TypeVar

import typer
from rich.console import Console

from cli.progress import count_bar

T = TypeVar("T")
app = typer.Typer(help="Train the learned models.", no_args_is_help=True)
CONFIGS = Path(__file__).resolve().parent.parent / "simcore" / "training" / "configs"
DEFAULT_CONFIG = CONFIGS / "skin_cpu.json"
SKELETON_CONFIG = CONFIGS / "skeleton_cpu.json"
ConfigOption = Annotated[Path, typer.Option("--config", exists=True, dir_okay=False, help="JSON training config")]
WorkersOption = Annotated[int, typer.Option(min=1, help="processes building characters at once (the samples are the same)")]


def read_config(config: Path) -> dict:
    """A JSON training config (or a cache's summary file) as a dict."""
    return json.loads(config.read_text(encoding="utf-8"))


def corpus_of(spec: dict) -> Path:
    """The corpus folder the config's "data" section names (both data builders' default when it names none)."""
    from simcore.training.characters import CORPUS

    return Path(spec.get("data", {}).get("corpus", CORPUS))


def train_section(spec: dict, model_config: Callable[..., object], train_config: Callable[..., T]) -> T:
    """The config's "train" section as `train_config`, its "model" part as `model_config`."""
    section = dict(spec.get("train", {}))
    section["model"] = model_config(**section.get("model", {}))
    return train_config(**section)


def _build(config: Path, build: Callable[..., dict], data_config: Callable[..., object], workers: int) -> None:
    """Run a sample builder on the config's "data" section into its "cache" on `workers` processes, with a progress bar."""
    spec = read_config(config)
    with count_bar("samples") as update:
        summary = build(data_config(**spec.get("data", {})), Path(spec["cache"]), update, workers)
    Console().print(f"train samples {summary['train']}, val samples {summary['val']}, failed characters {summary['failed']}")
    for name, why in summary["skipped"].items():
        Console().print(f"[yellow]skipped[/] {name}: {why}")


def _train(config: Path, data_command: str, train_command: str, model_config: Callable[..., object],
           train_config: Callable[..., object], train: Callable[..., dict], write_card: Callable[..., Path], score: str) -> dict:
    """Train on the config's cache, write the weights and their card; `score` is the val figure the bar shows."""
    spec = read_config(config)
    log = Path(spec["log"])
    log.parent.mkdir(parents=True, exist_ok=True)

    def describe(entry: dict) -> str:
        parts = [f"loss {entry['loss']:.4f}"] if "loss" in entry else []
        if "val" in entry:
            parts.append(f"val {score} {entry['val'][score.lower()]:.4f}")
        return ", ".join(parts)

    with count_bar("training") as update:
        summary = train(train_section(spec, model_config, train_config), Path(spec["cache"]), Path(spec["out"]), log,
                        lambda step, total, entry: update(describe(entry), step, total))
    cache = Path(spec["cache"])
    card = write_card(Path(spec["out"]), summary, read_config(cache / "summary.json"), read_config(cache / "data_config.json"),
                      f"rigforge train {data_command} --config {config} && rigforge train {train_command} --config {config}")
    Console().print(f"model card: {card}")
    return summary


@app.command("data")
def data(config: ConfigOption = DEFAULT_CONFIG, workers: WorkersOption = 1) -> None:
    """Build (or complete) the sample cache: corpus train/val characters, augmented, and anny bodies."""
    from simcore.training.skin_dataset import DataConfig, build_skin_data  # torch and anny load only for training

    _build(config, build_skin_data, DataConfig, workers)


@app.command("skin")
def skin(config: ConfigOption = DEFAULT_CONFIG) -> None:
    """Train the skinning model on the cache, keep the best `val` state, write the .safetensors and its card; with an
    "ensemble" section ({"folds": N, "workers": W}), one member per group of corpus train families, saved as one."""
    from simcore.skinning.attention_model import ModelConfig
    from simcore.training.model_card import write_model_card
    from simcore.training.skin_ensemble import FamilyEnsemble, train_ensemble
    from simcore.training.skin_train import TrainConfig, train_skin

    spec = read_config(config)
    ensemble = FamilyEnsemble(**spec.get("ensemble", {}))
    corpus = corpus_of(spec)

    def train_members(train: TrainConfig, cache: Path, out: Path, log: Path, report: Callable[[int, int, dict], None]) -> dict:
        return train_ensemble(train, ensemble, cache, corpus, out, log, lambda done, total: report(done, total, {}))

    summary = _train(config, "data", "skin", ModelConfig, TrainConfig, train_members if ensemble.folds else train_skin,
                     write_model_card, "L1")
    where = (f"{len(summary['members'])} members, best steps {', '.join(str(m['best_step']) for m in summary['members'])}"
             if ensemble.folds else f"step {summary['best_step']}")
    Console().print(f"best val L1 {summary['val']['l1']:.4f}, deformation {summary['val']['deform']:.5f} at {where} "
                    f"(start {summary['val_at_start']['l1']:.4f}); {summary['seconds']:.0f} s")


@app.command("skeleton-data")
def skeleton_data(config: ConfigOption = SKELETON_CONFIG, workers: WorkersOption = 1) -> None:
    """Build (or complete) the skeleton model's sample cache: points, class and tokens of each augmented character."""
    from simcore.training.skeleton_dataset import SkeletonDataConfig, build_skeleton_data

    _build(config, build_skeleton_data, SkeletonDataConfig, workers)


@app.command("skeleton")
def skeleton(config: ConfigOption = SKELETON_CONFIG) -> None:
    """Train the skeleton-token model on the cache, keep the best `val` state, write the .safetensors and its card."""
    from simcore.skeleton.learned_model import SkeletonModelConfig
    from simcore.training.skeleton_card import write_skeleton_card
    from simcore.training.skeleton_train import SkeletonTrainConfig, train_skeleton

    summary = _train(config, "skeleton-data", "skeleton", SkeletonModelConfig, SkeletonTrainConfig, train_skeleton,
                     write_skeleton_card, "NLL")
    Console().print(f"best val NLL {summary['val']['nll']:.4f} (start {summary['val_at_start']['nll']:.4f}), decoded J2J "
                    f"{summary['val']['j2j']:.4f} at step {summary['best_step']}; {summary['seconds']:.0f} s")
