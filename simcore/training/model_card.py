"""The skinning model's card: data, augmentations, steps, seed, hardware, time, val scores (shared parts in card.py)."""

from __future__ import annotations

import json
from pathlib import Path

from simcore.training.card import corpus_line, creatures_lines, hardware_line, write_card


def write_model_card(weights: Path, summary: dict, data_summary: dict, data_config: dict, command: str) -> Path:
    """Write <weights stem>.md beside the weights file and return its path."""
    train = summary["config"]
    about = [
        "Predicts per-vertex skinning weights for a mesh and a given skeleton (see simcore/skinning/attention_model.py).",
        "Inputs are each vertex's 16 geodesically nearest joints with distance and tree features (simcore/skinning/pair_features.py);",
        "the output refines the geodesic voxel binding's log-weights (an untrained model reproduces them).",
        "In use (simcore/skinning/learned.py) its weights are multiplied by that prior's to the power PRIOR_SHARE, a product",
        "of experts chosen by held-out family (`--prior-share` of `rigforge eval skin` and `rigforge train skin-cv` tries others);",
        "the val scores below are the model's own.",
    ]
    data = [
        corpus_line(data_config),
        f"- {data_config['anny_bodies']} `anny` bodies (random phenotype; rigs in turn: "
        f"{', '.join(data_config.get('anny_rigs', ('mixamo', 'game_engine')))}), {data_config['anny_variants']} variants each",
        *creatures_lines(data_config),
        f"- {data_config['variants']} variants of each corpus character: the bind pose, frames of its own clips and random poses "
        f"(±{data_config['pose_degrees']:g}°/√3 per axis) skinned with the artist weights, mid-edge subdivision on every other variant, "
        "a random turn about up and scale in [0.5, 2]",
        *([f"- each variant after the first loses its unweighted armature root with chance {data_config['reroot']:g} (its heaviest "
            "child becomes the root and takes its weight), so the model also sees roots that bend the mesh"] if data_config.get("reroot") else []),
        f"- {data_config['vertices']} random vertices kept per training sample, {data_config['val_vertices']} per val character",
        f"- samples: {summary['train_samples']} train, {summary['val_samples']} val; per category: {json.dumps(summary['categories'])}; "
        f"characters that failed to build: {data_summary.get('failed', 0)}",
    ]
    members = summary.get("members", [])
    training = [
        f"- steps {train['steps']}, batch {train['batch']} samples × {train['points']} vertices, AdamW lr {train['lr']} (one-cycle), "
        f"weight decay {train['weight_decay']:g}, loss L1 + {train['kl']} × CE + {train['deform']} × deformation, seed {train['seed']}",
        *([f"- the weights' exponential moving average (decay {train['ema']:g} a step) is what is validated and saved"]
          if train["ema"] else []),
        f"- network: {json.dumps(train['model'])}; {weights.stat().st_size / 1e6:.2f} MB",
        hardware_line(summary),
        *([f"- {len(members)} members (simcore/training/skin_ensemble.py): one on every family, the others each without one "
           "group of corpus train families (the folds of `rigforge train skin-cv`); their logits are averaged, and they are stored "
           "best first by their own val L1 (a character too large for all of them is read by the first ones)",
           *(f"  - member {k}: {_member_data(m)}, {m['steps']} steps, best val state at step {m['best_step']}"
             for k, m in enumerate(members))]
          if members else [f"- best val state at step {summary['best_step']}"]),
    ]
    scores = [
        "## Val scores (corpus `val`, vertices sampled, model output before top-k)",
        "",
        "| | L1 | deformation (unit cube) |",
        "|---|---|---|",
        f"| geodesic prior (untrained) | {summary['val_at_start']['l1']:.4f} | {summary['val_at_start']['deform']:.5f} |",
        *(f"| member {k} alone | {m['val']['l1']:.4f} | {m['val']['deform']:.5f} |" for k, m in enumerate(members)),
        f"| learned{' (the ensemble)' if members else ''} | {summary['val']['l1']:.4f} | {summary['val']['deform']:.5f} |",
        "",
        "Evaluation tables with the full post-processing: `rigforge eval skin ../shared/corpus --split val --method all` and",
        "`rigforge eval skin ../shared/assets/dev --method all`.",
    ]
    return write_card(weights, "learned skinning weights (bone–point attention)", about, command, data, training, scores)


def _member_data(member: dict) -> str:
    """What an ensemble member trained on, in words."""
    held = member["held_out"]
    return f"without {len(held)} characters ({', '.join(held[:3])}, …)" if held else "every family"
