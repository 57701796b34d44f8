"""`rigforge eval skeleton DIR [--method M ...] [--ablate] [--json FILE]`: skeleton metrics over a directory of rigs."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

from simcore.errors import SimcoreError

_COLUMNS = ("asset", "category", "method", "J2J", "J2B", "B2B", "joints pred/gt", "inside", "s", "note")


def _fmt(value: float | None, digits: int = 4) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def _delta(value: float | None) -> str:
    return "-" if value is None else f"{value:+.4f}"


def metric_cells(row: dict) -> list[str]:
    if "j2j" not in row:
        return ["-", "-", "-", "-", "-"]
    return [_fmt(row["j2j"]), _fmt(row["j2b"]), _fmt(row["b2b"]),
            f"{row['joints_pred']:.4g}/{row['joints_gt']:.4g}", _fmt(row["inside"], 2)]


def render(report: dict, console: Console) -> None:
    """Print the per-asset table (with a mean row per method) and the per-category means."""
    table = Table(*_COLUMNS, title="Skeleton evaluation (unit-cube units: GT mesh bbox, longest side 1)")
    for row in report["assets"]:
        note = row.get("error") or row.get("note") or ""
        table.add_row(row["name"], row["category"], row["method"], *metric_cells(row), _fmt(row["seconds"], 2), note)
    for method, mean in report["mean"].items():
        note = f"{mean['assets']} assets" + (f", {mean['failed']} failed" if mean["failed"] else "")
        if "joint_ratio_ok" in mean:
            note += f", joints 0.5-2x {mean['joint_ratio_ok']:.0%}"
        if "beats_voxel" in mean:
            note += f", beats voxel {mean['beats_voxel']:.0%}"
        if "j2j_matched" in mean:
            note += f", J2J without extra joints {mean['j2j_matched']:.4f}"
        table.add_row("MEAN", "", method, *metric_cells(mean), _fmt(mean.get("seconds"), 2), note, style="bold")
    console.print(table)
    cats = Table("category", "method", "assets", "J2J", "J2B", "B2B", "joints pred/gt", "inside", title="Per-category means")
    for method, by_cat in report["by_category"].items():
        for category, mean in by_cat.items():
            if mean["assets"]:
                cats.add_row(category, method, str(mean["assets"]), *metric_cells(mean))
    console.print(cats)
    tokens = report["tokens"]
    if tokens["skeletons"]:
        console.print(f"Ground-truth skeleton tokens over {tokens['skeletons']} rigs: naive {tokens['naive']}, "
                      f"optimised {tokens['optimized']}, saving {tokens['saving']:.1%} (UniRig reports 27-30 %)")
    for name, reason in report["skipped"].items():
        console.print(f"skipped {name}: {reason}")


def render_ablation(report: dict, console: Console) -> None:
    """Print the ablation table: each geometric rule turned off, its mean J2J/B2B and change, assets worse/better."""
    table = Table("variant", "J2J", "ΔJ2J", "B2B", "ΔB2B", "J2J worse/better", "rule",
                  title="Geometric rules ablated (job path; Δ > 0: turning the rule off hurts, so the rule helps)")
    for row in report["table"]:
        table.add_row(row["variant"], _fmt(row["j2j"]), _delta(row["d_j2j"]), _fmt(row["b2b"]), _delta(row["d_b2b"]),
                      f"{row['worse']}/{row['better']}", row["rule"])
    console.print(table)
    for name, reason in report["skipped"].items():
        console.print(f"skipped {name}: {reason}")


def eval_skeleton(
    dir: Annotated[Path, typer.Argument(help="directory of rigged .glb/.gltf files (MANIFEST.tsv optional)")],
    method: Annotated[list[str] | None, typer.Option("--method", help="all | voxel | auto | geometric | humanoid | learned; "
                                                                       "repeat it for several (default: all)")] = None,
    json_path: Annotated[Path | None, typer.Option("--json", help="write the report as JSON here")] = None,
    max_joints: Annotated[int, typer.Option("--max-joints", help="joint cap for the predicted methods")] = 64,
    split: Annotated[str | None, typer.Option(help="only the files DIR/MANIFEST.tsv lists for this split (train, val)")] = None,
    ablate: Annotated[bool, typer.Option("--ablate", help="the geometric method with each special-case rule off in turn "
                                                          "(--method is ignored)")] = False,
    model: Annotated[Path | None, typer.Option(exists=True, dir_okay=False,
                                               help="learned skeleton weights (.safetensors) to score instead of the shipped "
                                                    "ones, e.g. a fresh `rigforge train skeleton` output")] = None,
) -> None:
    """Score predicted skeletons against each rig's used skin joints (the job's ingest and prediction): J2J, J2B,
    B2B, joint counts, inside share; or, with --ablate, what each geometric rule changes."""
    from simcore.evaluation.skeleton_ablation import ablate_directory
    from simcore.evaluation.skeleton_eval import evaluate_directory

    console = Console() if sys.stdout.isatty() else Console(width=170)  # piped output keeps whole rows
    try:
        with console.status("evaluating") as status:
            def on_asset(name: str) -> None:
                status.update(f"evaluating {name}")
                if not console.is_terminal:
                    console.print(f"evaluating {name}")

            if ablate:
                report = ablate_directory(dir, max_joints=max_joints, split=split, on_asset=on_asset).to_dict()
            else:
                report = evaluate_directory(dir, method or "all", max_joints=max_joints, split=split, on_asset=on_asset,
                                            learned_model=model).to_dict()
    except SimcoreError as exc:
        console.print(f"[red]{exc.code}[/red]: {exc}")
        raise typer.Exit(2) from exc
    (render_ablation if ablate else render)(report, console)
    if json_path is not None:
        json_path.write_text(json.dumps(report, indent=1))
        console.print(f"wrote {json_path}")
