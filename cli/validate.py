"""`rigforge validate FILE...`: Khronos glTF validator for .glb/.gltf, usd-core compliance checks for USD.

Register in cli/main.py with `app.command("validate")(validate.validate)`; also runs alone as
`python -m cli.validate FILE...`. Exit status: 0 when every file has 0 errors, 1 otherwise, 2 when a
validator is not installed.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

GLTF_SUFFIXES = {".glb", ".gltf"}
USD_SUFFIXES = {".usd", ".usda", ".usdc", ".usdz"}


def _print_messages(messages: list) -> None:
    for message in messages[:20]:
        if isinstance(message, dict):
            typer.echo(f"    {message.get('code', '')} {message.get('pointer', '')}: {message.get('message', '')}")
        else:
            typer.echo(f"    {message}")


def validate(
    files: Annotated[list[Path], typer.Argument(exists=True, dir_okay=False, help="GLB/glTF or USD files")],
) -> None:
    """Validate exported files; print a summary per file and exit non-zero on any error."""
    from simcore.io.gltf_validate import ValidatorUnavailable, validate_gltf_files
    from simcore.io.usd_validate import validate_usd_file

    unknown = [f for f in files if f.suffix.lower() not in GLTF_SUFFIXES | USD_SUFFIXES]
    if unknown:
        typer.echo(f"unsupported file type: {', '.join(map(str, unknown))} (expected .glb/.gltf/.usd*)", err=True)
        raise typer.Exit(2)
    failed = False
    gltf_files = [f for f in files if f.suffix.lower() in GLTF_SUFFIXES]
    try:
        gltf_results = validate_gltf_files(gltf_files)
    except ValidatorUnavailable as exc:
        typer.echo(f"cannot validate glTF: {exc}", err=True)
        raise typer.Exit(2) from exc
    for res in gltf_results:
        failed |= not res.ok
        typer.echo(f"{'FAIL' if not res.ok else 'ok  '} {res.path}: {res.errors} errors, {res.warnings} warnings, "
                   f"{res.infos} infos, {res.hints} hints ({res.validator})")
        _print_messages(res.messages)
    for path in (f for f in files if f.suffix.lower() in USD_SUFFIXES):
        usd = validate_usd_file(path)
        failed |= not usd.ok
        typer.echo(f"{'FAIL' if not usd.ok else 'ok  '} {path}: {len(usd.errors)} errors, "
                   f"{len(usd.warnings)} warnings ({usd.checker})")
        _print_messages(usd.errors + usd.warnings)
    if failed:
        raise typer.Exit(1)


if __name__ == "__main__":
    typer.run(validate)
