"""`rigforge fit SEQUENCE.glb [...]`: PhysRig inverse skinning (materials + driving velocities) vs an LBS baseline.

Registered in cli/main.py as `app.command()(fit.fit)`. For each mesh sequence, both methods get the same
skeleton (predicted on frame 0; `--drivers virtual` for farthest-point virtual joints) and the same number
of optimiser steps, in two protocols: pure fitting (every frame) and train/test (fit the first part, then
with the shared parameters frozen fit only the per-frame motion of the rest; chamfer on the rest).
Defaults are sized for 2 CPU cores (grid 32, 3k particles, 5 iterations per phase); the flags scale to the
paper's settings (e.g. --grid 100 --substeps 100 --material-iters 20 --velocity-iters 30 --particles 50000
on a GPU). Ablations: --no-learn-mixing, --material-iters 0 (no material phase), --drivers virtual,
--drive velocity (the paper's open-loop integrated velocities instead of driving points aimed at per-frame anchors),
--initial-motion (particles start with their joints' motion; off by default).
Where the error comes from: `--breakdown 32,64,96` runs, at each grid (particles and substeps scaled to keep their
density and length in cells), forward runs told more and more of the answer (`simcore.mpm.fit_breakdown`);
`--protocol none` skips the fits:

    rigforge fit ../shared/assets/dev/meshseq_horse.glb ../shared/assets/dev/meshseq_flamingo.glb --protocol none --breakdown 32,64,96

    rigforge fit ../shared/assets/dev/meshseq_horse.glb ../shared/assets/dev/meshseq_flamingo.glb --json out.json
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table


def _table(title: str, row: dict) -> Table:
    table = Table(title=title)
    for head in ("frame", "physics", "LBS"):
        table.add_column(head, justify="right")
    for f, p, b in zip(row["frames"], row["physics"], row["lbs"]):
        table.add_row(str(f), f"{p:.4f}", f"{b:.4f}")
    table.add_row("mean", f"{row['mean_physics']:.4f}", f"{row['mean_lbs']:.4f}", style="bold")
    return table


BREAKDOWN_ROWS = {
    "observed": "every particle driven along the observed motion (the solver's floor)",
    "anchor_motion": "every particle driven by its joints' rigid motions (all the drivers know)",
    "drivers": "the fit's driving points, the material carries the rest (physics before fitting)",
    "lbs_motion": "LBS: coarse weights and the same rigid motions, no optimiser step",
}


def _breakdown_table(title: str, runs: list[dict]) -> Table:
    table = Table(title=title)
    table.add_column("forward run")
    for run in runs:
        table.add_column(f"grid {run['grid']} ({run['particles']} p)", justify="right")
    for key, label in BREAKDOWN_ROWS.items():
        table.add_row(label, *(f"{run['rows'][key]['mean']:.4f}" for run in runs))
    return table


def fit(
    sequences: Annotated[list[Path], typer.Argument(help="glTF/GLB files with a morph-target animation (deforming mesh, no skin)")],
    frames: Annotated[int, typer.Option(help="frames to fit from the clip start (0: all)")] = 0,
    fps: Annotated[float, typer.Option(help="sampling rate of the sequence (the paper: 25)")] = 25.0,
    protocol: Annotated[str, typer.Option(help="pure, train_test, both or none")] = "both",
    train_fraction: Annotated[float, typer.Option(help="train/test: share of the frames fitted first")] = 0.5,
    grid: Annotated[int, typer.Option(help="grid nodes per axis")] = 32,
    substeps: Annotated[int, typer.Option(help="substeps per frame")] = 25,
    particles: Annotated[int, typer.Option(help="particle budget")] = 3000,
    prototypes: Annotated[int, typer.Option(help="material prototypes")] = 25,
    drivers: Annotated[str, typer.Option(help="skeleton (predicted on frame 0) or virtual (farthest-point joints)")] = "skeleton",
    joints: Annotated[int, typer.Option(help="virtual joints, or the predicted skeleton's joints at most")] = 24,
    learn_mixing: Annotated[bool, typer.Option(help="learn prototype centres, axes and radii with E")] = True,
    drive: Annotated[str, typer.Option(help="anchored (driving points aimed at per-frame anchors) or velocity (open loop)")] = "anchored",
    initial_motion: Annotated[bool, typer.Option(help="particles start with their joints' motion (else at rest)")] = False,
    cycles: Annotated[int, typer.Option(help="alternating cycles")] = 3,
    material_iters: Annotated[int, typer.Option(help="AdamW steps per material phase (paper: 20)")] = 5,
    velocity_iters: Annotated[int, typer.Option(help="SGD steps per frame per velocity phase (paper: 30)")] = 5,
    velocity_lr: Annotated[float, typer.Option(help="SGD learning rate, velocities in cells/frame; materials get 20×")] = 0.01,
    breakdown: Annotated[str, typer.Option(help="grids for the error breakdown, comma-separated (empty: none)")] = "",
    synthetic: Annotated[bool, typer.Option(help="also run the synthetic material-recovery case")] = False,
    device: Annotated[str | None, typer.Option(help="warp device (default: CUDA when present)")] = None,
    json_out: Annotated[Path | None, typer.Option("--json", help="write the results here")] = None,
) -> None:
    """Fit PhysRig materials and driving-point velocities to mesh sequences; compare with LBS at the same budget."""
    import torch

    from simcore.io.gltf_document import GltfDocument
    from simcore.io.gltf_morph_sequence import read_morph_sequence
    from simcore.mpm.fit import FitConfig
    from simcore.mpm.fit_experiment import fit_sequence, recover_materials

    if protocol not in ("pure", "train_test", "both", "none"):
        raise typer.BadParameter("pure, train_test, both or none", param_hint="--protocol")
    try:
        grids = tuple(int(g) for g in breakdown.split(",") if g.strip())
    except ValueError:
        raise typer.BadParameter("comma-separated grid sizes, e.g. 32,64", param_hint="--breakdown") from None
    if any(g < 16 for g in grids):
        raise typer.BadParameter("grids of 16 nodes or more", param_hint="--breakdown")
    if drivers not in ("skeleton", "virtual"):
        raise typer.BadParameter("skeleton or virtual", param_hint="--drivers")
    if drive not in ("anchored", "velocity"):
        raise typer.BadParameter("anchored or velocity", param_hint="--drive")
    torch.set_num_threads(1)
    console = Console()
    config = FitConfig(grid=grid, substeps=substeps, max_particles=particles, prototypes=prototypes,
                       virtual_joints=joints, max_joints=joints, cycles=cycles, material_iters=material_iters,
                       velocity_iters=velocity_iters, velocity_lr=velocity_lr, device=device, drivers=drivers,
                       learn_mixing=learn_mixing, drive=drive, initial_motion=initial_motion)
    protocols: tuple[str, ...] = {"both": ("pure", "train_test"), "none": ()}.get(protocol, (protocol,))
    result: dict = {}
    for path in sequences:
        seq = read_morph_sequence(GltfDocument.from_bytes(path.read_bytes()), fps=fps, max_frames=frames or None)
        console.print(f"{path.name}: {seq.frames.shape[1]} vertices, {len(seq.frames)} frames at {seq.fps:g} fps")
        r = fit_sequence(seq.frames, seq.faces, seq.fps, config, train_fraction, protocols, log=console.print,
                         breakdown_grids=grids)
        result[path.stem] = r
        if grids:
            console.print(_breakdown_table(f"{path.stem}: where the error comes from, chamfer ×100 ({r['units']})", r["breakdown"]))
        for name in protocols:
            console.print(_table(f"{path.stem}, {name}: chamfer per frame ({r['units']})", r[name]))
        if json_out:  # after each sequence, so a long run leaves what it finished
            json_out.parent.mkdir(parents=True, exist_ok=True)
            json_out.write_text(json.dumps(result, indent=2))
    if synthetic:
        syn = recover_materials(config, log=console.print)
        result["synthetic"] = syn
        table = Table(title="Synthetic material recovery (two prototypes, E in Pa)")
        for head in ("prototype", "true E", "initial E", "fitted E", "relative error"):
            table.add_column(head, justify="right")
        for p, (t, i, f, e) in enumerate(zip(syn["true_E_Pa"], syn["initial_E_Pa"], syn["fitted_E_Pa"], syn["relative_error"])):
            table.add_row(str(p), f"{t:.0f}", f"{i:.0f}", f"{f:.0f}", f"{e:.3f}")
        console.print(table)
    if json_out:
        json_out.parent.mkdir(parents=True, exist_ok=True)
        json_out.write_text(json.dumps(result, indent=2))
        console.print(f"wrote {json_out}")
