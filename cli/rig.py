"""`rigforge rig INPUT`: the whole pipeline in-process, no server."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from cli.progress import stage_bar


def _read_format(path: Path, kind: str, field: str) -> str:
    from simcore.io.sniff import require_kind, sniff

    with path.open("rb") as f:
        head = f.read(64 * 1024)
    return require_kind(sniff(head, path.stat().st_size), kind, field)


def rig(
    input: Annotated[Path, typer.Argument(exists=True, dir_okay=False, help="mesh: GLB, glTF, OBJ, PLY or STL")],
    output: Annotated[Path, typer.Option("-o", "--output", help="output directory")] = Path("rigged"),
    motion: Annotated[Path | None, typer.Option(exists=True, dir_okay=False, help="motion clip: BVH or GLB")] = None,
    options: Annotated[str, typer.Option(help="JobOptions as JSON")] = "{}",
    skeleton: Annotated[Path | None, typer.Option(exists=True, dir_okay=False,
                                                  help="an edited skeleton.json to re-skin with (needs skeleton: keep)")] = None,
) -> None:
    """Rig one file locally and write the artifacts to OUTPUT."""
    from api.settings import get_settings
    from cli.job_options import parse_job_options
    from simcore.errors import SimcoreError
    from simcore.pipeline import PipelineInputs, run_pipeline

    opts = parse_job_options(options)
    try:
        inputs = PipelineInputs(input, _read_format(input, "mesh", "mesh"),
                                motion, _read_format(motion, "motion", "motion") if motion else None,
                                skeleton_path=skeleton)
        with stage_bar(input.name) as update:
            state = run_pipeline(inputs, opts, output, update, budgets=get_settings().budgets)
    except SimcoreError as exc:
        typer.echo(f"error [{exc.code}]{f' ({exc.field})' if exc.field else ''}: {exc}", err=True)
        raise typer.Exit(1) from exc
    for _name, path in sorted(state.artifacts.items()):
        typer.echo(f"{path}  ({path.stat().st_size} bytes)")
