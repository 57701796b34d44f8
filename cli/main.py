"""The `rigforge` command line."""

from __future__ import annotations

import sys

import typer

from cli import (
    eval_gate,
    eval_motion,
    eval_motion_rig,
    eval_parts,
    eval_skeleton,
    eval_skin,
    fit,
    jobs,
    keys,
    rig,
    server,
    submit,
    train,
    train_skeleton_cv,
    train_skin_cv,
    validate,
)

app = typer.Typer(help="RigForge: automatic rigging and skinning.", no_args_is_help=True, pretty_exceptions_enable=False)
eval_app = typer.Typer(help="Quality evaluations on a directory of rigged assets.", no_args_is_help=True)

app.command()(server.serve)
app.command()(server.worker)
app.command()(server.migrate)
app.add_typer(keys.app, name="keys")
app.command()(rig.rig)
app.command()(submit.submit)
app.add_typer(jobs.app, name="jobs")
app.command()(validate.validate)
app.command()(fit.fit)
app.add_typer(eval_app, name="eval")
train.app.command("skin-cv")(train_skin_cv.skin_cv)
train.app.command("skeleton-cv")(train_skeleton_cv.skeleton_cv)
app.add_typer(train.app, name="train")
eval_app.command("skeleton")(eval_skeleton.eval_skeleton)
eval_app.command("skin")(eval_skin.eval_skin)
eval_app.command("motion")(eval_motion.eval_motion)
eval_app.command("motion-rig")(eval_motion_rig.eval_motion_rig)
eval_app.command("gate")(eval_gate.eval_gate)
eval_app.command("parts")(eval_parts.eval_parts)


def main() -> None:
    """The console entry point: `app`, with any input error a command did not handle itself printed as one line
    (code, field, message) and exit status 2 instead of a traceback."""
    from simcore.errors import SimcoreError

    try:
        app()
    except SimcoreError as exc:
        typer.echo(f"error [{exc.code}]{f' ({exc.field})' if exc.field else ''}: {exc}", err=True)
        sys.exit(2)


if __name__ == "__main__":
    main()
