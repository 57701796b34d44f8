"""`rigforge eval motion-rig DIR [--motion sequence|clip|random ...] [--split S] [--only NAME ...] [--json FILE]`.

Rigs recovered from mesh sequences (simcore.evaluation.motion_rig_eval). Registered in cli/main.py as
`eval_app.command("motion-rig")(eval_motion_rig.eval_motion_rig)`.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

from cli.eval_output import print_table_and_problems, write_report_json
from simcore.evaluation.motion_rig_eval import MOTIONS, MotionRigEvaluation, evaluate_motion_rig


def _fmt(value: float | None, digits: int) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def render(report: MotionRigEvaluation, console: Console) -> None:
    """One row per sequence (rig and free Dem Bones side by side), then the means per motion."""
    table = Table(title="Rigs from motion: RMSE in first-frame bbox diagonals (rig vs free-bone Dem Bones at the same "
                        "count); J2J/B2B in unit-cube units vs the artist's skeleton (motion: the joints read off the "
                        "motion alone; free: the free bones' centres); bones: every joint, shape: those of them placed "
                        "from the mesh's shape, out: joints outside it")
    for head in ("sequence", "motion", "frames", "vertices", "bones", "shape", "sliding", "out"):
        table.add_column(head)
    for head in ("rmse rig", "rmse free", "ratio", "J2J", "B2B", "J2J motion", "J2J free", "gt joints", "s"):
        table.add_column(head, justify="right")
    for r in report.rows:
        cells = [r.name, r.motion, str(r.frames), str(r.vertices), str(r.bones), str(r.shape_joints), str(r.sliding),
                 str(r.outside)]
        if r.error:
            table.add_row(*cells, "error", "", "", "", "", "", "", "", _fmt(r.seconds, 1))
            continue
        table.add_row(*cells, _fmt(r.rmse, 5), _fmt(r.free_rmse, 5), _fmt(r.ratio, 3), _fmt(r.j2j, 4), _fmt(r.b2b, 4),
                      _fmt(r.motion_j2j, 4), _fmt(r.free_j2j, 4), "-" if r.joints_truth is None else str(r.joints_truth), _fmt(r.seconds, 1))
    for motion in MOTIONS:
        if not any(r.motion == motion and not r.error for r in report.rows):
            continue
        table.add_row("MEAN", motion, "", "", "", "", "", "", _fmt(report.mean("rmse", motion), 5),
                      _fmt(report.mean("free_rmse", motion), 5), _fmt(report.mean("ratio", motion), 3),
                      _fmt(report.mean("j2j", motion), 4), _fmt(report.mean("b2b", motion), 4),
                      _fmt(report.mean("motion_j2j", motion), 4), _fmt(report.mean("free_j2j", motion), 4), "", "",
                      style="bold")
    print_table_and_problems(console, table, report.skipped, (f"{r.name} {r.motion}: {r.error}" for r in report.rows if r.error))


def eval_motion_rig(
    directory: Annotated[Path, typer.Argument(exists=True, file_okay=False,
                                              help="folder of mesh-sequence files and rigged .glb/.gltf")],
    motion: Annotated[list[str] | None, typer.Option(help="sequence (the folder's mesh sequences), clip (each rig's "
                                                          "own clip), random (a seeded random motion); default all")] = None,
    split: Annotated[str | None, typer.Option(help="only the rigs MANIFEST.tsv lists for this split")] = None,
    frames: Annotated[int, typer.Option(min=2, help="frames of each posed sequence")] = 60,
    only: Annotated[list[str] | None, typer.Option(help="evaluate only these names")] = None,
    json_path: Annotated[Path | None, typer.Option("--json", help="write the JSON report here")] = None,
) -> None:
    """Rig each mesh sequence from its motion; compare with free Dem Bones and the artist's skeleton."""
    motions = tuple(motion or MOTIONS)
    unknown = sorted(set(motions) - set(MOTIONS))
    if unknown:
        raise typer.BadParameter(f"unknown motion {unknown[0]!r}; choose from {', '.join(MOTIONS)}", param_hint="--motion")
    tty = sys.stderr.isatty()
    console = Console(width=None if sys.stdout.isatty() else 200)  # a log keeps every column
    with console.status("rigging from motion…") as status:
        def on_row(name: str) -> None:
            if tty:
                status.update(f"rigging {name} from its motion")
            else:
                print(f"rigging {name}", file=sys.stderr, flush=True)

        report = evaluate_motion_rig(directory, motions=motions, split=split, max_frames=frames,
                                     only=set(only) if only else None, on_row=on_row)
    render(report, console)
    write_report_json(console, json_path, report.to_dict())


if __name__ == "__main__":
    typer.run(eval_motion_rig)
