"""`rigforge fit MESH_SEQUENCE.glb`: PhysRig inverse skinning (materials + driving velocities) vs an LBS baseline.

Registered in cli/main.py as `app.command()(fit.fit)`. Defaults are sized for 2 CPU cores (4 frames, grid 32,
3k particles, 5 iterations per phase); the flags scale to the paper's settings (e.g. --grid 100 --substeps 100
--material-iters 20 --velocity-iters 30 --particles 50000 on a GPU).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table


def _table(title: str, columns: dict[str, list[float]]) -> Table:
    table = Table(title=title)
    table.add_column("frame", justify="right")
    for name in columns:
        table.add_column(name, justify="right")
    rows = len(next(iter(columns.values())))
    for t in range(rows):
        table.add_row(str(t), *[f"{columns[c][t]:.4f}" for c in columns])
    table.add_row("mean (frames ≥ 1)", *[f"{sum(v[1:]) / max(len(v) - 1, 1):.4f}" for v in columns.values()], style="bold")
    return table


def fit(
    sequence: Annotated[Path, typer.Argument(help="glTF/GLB with a morph-target animation (deforming mesh, no skin)")],
    frames: Annotated[int, typer.Option(help="frames to fit, from the clip start")] = 4,
    fps: Annotated[float, typer.Option(help="sampling rate of the sequence (the paper: 25)")] = 25.0,
    grid: Annotated[int, typer.Option(help="grid nodes per axis")] = 32,
    substeps: Annotated[int, typer.Option(help="substeps per frame")] = 25,
    particles: Annotated[int, typer.Option(help="particle budget")] = 3000,
    prototypes: Annotated[int, typer.Option(help="material prototypes")] = 25,
    joints: Annotated[int, typer.Option(help="virtual joints (8 driving points each)")] = 12,
    cycles: Annotated[int, typer.Option(help="alternating cycles")] = 3,
    material_iters: Annotated[int, typer.Option(help="AdamW steps per material phase (paper: 20)")] = 5,
    velocity_iters: Annotated[int, typer.Option(help="SGD steps per frame per velocity phase (paper: 30)")] = 5,
    velocity_lr: Annotated[float, typer.Option(help="SGD learning rate, velocities in cells/frame; materials get 20×")] = 0.01,
    synthetic: Annotated[bool, typer.Option(help="also run the synthetic material-recovery case")] = True,
    device: Annotated[str | None, typer.Option(help="warp device (default: CUDA when present)")] = None,
    json_out: Annotated[Path | None, typer.Option("--json", help="write the results here")] = None,
) -> None:
    """Fit PhysRig materials and driving-point velocities to a mesh sequence; compare with LBS at the same budget."""
    from simcore.io.gltf_document import GltfDocument
    from simcore.io.gltf_morph_sequence import read_morph_sequence
    from simcore.mpm.fit import FitConfig
    from simcore.mpm.fit_experiment import fit_sequence, recover_materials

    console = Console()
    config = FitConfig(grid=grid, substeps=substeps, max_particles=particles, prototypes=prototypes,
                       virtual_joints=joints, cycles=cycles, material_iters=material_iters,
                       velocity_iters=velocity_iters, velocity_lr=velocity_lr, device=device)
    seq = read_morph_sequence(GltfDocument.from_bytes(sequence.read_bytes()), fps=fps, max_frames=frames)
    console.print(f"{sequence.name}: {seq.frames.shape[1]} vertices, {len(seq.frames)} frames at {seq.fps:g} fps")
    result = {"sequence": fit_sequence(seq.frames, seq.faces, seq.fps, config, log=console.print)}
    r = result["sequence"]
    console.print(_table(f"Chamfer per frame ({r['units']})",
                         {"physics init": r["chamfer_physics_init"], "physics fit": r["chamfer_physics"], "LBS fit": r["chamfer_lbs"]}))
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
