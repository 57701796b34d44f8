"""`rigforge eval motion DIR [--artist-only] [--only NAME ...] [--split SPLIT] [--options JSON] [--json FILE]`: clip
retargeting quality.

Registered in cli/main.py as `eval_app.command("motion")(eval_motion.eval_motion)`.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.console import Console
from rich.table import Table

from cli.eval_output import print_table_and_problems, write_report_json

if TYPE_CHECKING:  # the evaluation imports the motion pipeline: loaded when the command runs, not with every `rigforge` call
    from simcore.evaluation.motion_eval import MotionEvaluation


def _fmt(value: float | None, digits: int) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def _volume(low: float | None, high: float | None) -> str:
    return "-" if low is None or high is None else f"{low:.3f}–{high:.3f}"


def render(report: MotionEvaluation, console: Console) -> None:
    """One row per character × rig (artist self-check, ours), then the means."""
    from simcore.evaluation.motion_eval import STRETCH_BOUND

    table = Table(title="Own clips retargeted artist rig → rig, LBS vertex error in unit-cube units; edge stretch "
                        "(length / bind length) ours and the artist rig's on the same clip (the artist's deviation floored at "
                        "`floor`); enclosed volume / bind volume, lowest–highest frame; "
                        "CMU 01_01 mocap foot sliding in heights/s; our rig is the job's (see `predictor` below) and `gate` its "
                        "quality-gate warnings on that clip")
    for head in ("asset", "category", "rig", "clip", "frames", "joints", "mapped", "map"):
        table.add_column(head)
    for head in ("err mean", "err p95", "stretch p1", "stretch p99", "artist p1", "artist p99", "floor", "× artist",
                 "volume", "artist volume", "mocap slide", "contact", "s"):
        table.add_column(head, justify="right")
    table.add_column("gate")
    for r in report.rows:
        cells = [r.name, r.category, r.target, r.clip, str(r.frames), str(r.joints), str(r.mapped), r.method]
        if r.error:
            table.add_row(*cells, "error", *[""] * 11, _fmt(r.seconds, 1), "")
            continue
        ratio = _fmt(r.stretch_ratio, 2) + ("" if r.within_bound is not False else " ✗")
        table.add_row(*cells, _fmt(r.vertex_error, 4), _fmt(r.vertex_error_p95, 4), _fmt(r.stretch_low, 3),
                      _fmt(r.stretch_high, 3), _fmt(r.artist_stretch_low, 3), _fmt(r.artist_stretch_high, 3),
                      _fmt(r.deviation_floor, 3), ratio, _volume(r.volume_low, r.volume_high),
                      _volume(r.artist_volume_low, r.artist_volume_high), _fmt(r.mocap_sliding, 4), _fmt(r.mocap_contact, 3),
                      _fmt(r.seconds, 1), ", ".join(r.warnings))
    for target in ("artist", "ours"):
        table.add_row("MEAN", "", target, "", "", "", "", "", _fmt(report.mean(target, "vertex_error"), 4),
                      _fmt(report.mean(target, "vertex_error_p95"), 4), *[""] * 8, _fmt(report.mean(target, "mocap_sliding"), 4),
                      "", "", "", style="bold")
    print_table_and_problems(console, table, report.skipped, (f"{r.name} {r.target}: {r.error}" for r in report.rows if r.error))
    within, measured = report.bound_counts()
    geomean = report.stretch_geomean()
    console.print(f"our rig within {STRETCH_BOUND}× the artist's stretch on the same clip: {within} of {measured} clips"
                  + ("" if geomean is None else f"; stretch ratio geometric mean {geomean:.3f}"))
    console.print(f"predictor: {report.predictor}")


def eval_motion(
    directory: Annotated[Path, typer.Argument(exists=True, file_okay=False, help="folder of rigged .glb/.gltf with clips (+ mocap_cmu_01_01.bvh)")],
    artist_only: Annotated[bool, typer.Option(help="only the self-check onto the artist skeleton")] = False,
    only: Annotated[list[str] | None, typer.Option(help="evaluate only these asset names")] = None,
    json_path: Annotated[Path | None, typer.Option("--json", help="write the JSON report here")] = None,
    split: Annotated[str | None, typer.Option(help="only the files DIR/MANIFEST.tsv lists for this split (train, val)")] = None,
    options: Annotated[str, typer.Option(help="JobOptions as JSON for our rig, e.g. '{\"skeleton\": \"keep\"}'")] = "{}",
    held_out: Annotated[bool, typer.Option(help="relax the weights under the character's next clip, then play "
                                                "this one on them (characters with one clip are error rows)")] = False,
) -> None:
    """Play each character's own clips on the rig a job makes and compare with the artist's animation."""
    from cli.job_options import parse_job_options
    from simcore.evaluation.motion_eval import evaluate_motion

    job_options = parse_job_options(options)
    console = Console()
    with console.status("retargeting…") as status:
        report = evaluate_motion(directory, use_predicted=not artist_only, only=set(only) if only else None, split=split,
                                 on_asset=lambda n: status.update(f"retargeting {n}"), options=job_options,
                                 held_out=held_out)
    render(report, console)
    write_report_json(console, json_path, report.to_dict())


if __name__ == "__main__":
    typer.run(eval_motion)
