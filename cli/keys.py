"""`rigforge keys create | list | revoke`: manage API keys (only hashes are stored) in the service's database."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.console import Console
from rich.table import Table

if TYPE_CHECKING:
    from sqlalchemy.orm import Session

app = typer.Typer(help="Manage API keys (run where the service's database is: its data directory or RIGFORGE_DATABASE_URL).",
                  no_args_is_help=True)
WHERE = "run this where `rigforge serve` keeps its data, or set RIGFORGE_DATA_DIR or RIGFORGE_DATABASE_URL"


def _fail(message: str) -> typer.Exit:
    typer.echo(f"error: {message}", err=True)
    return typer.Exit(1)


@contextmanager
def key_store() -> Iterator[Session]:
    """A session on the service's database; a missing or unmigrated one ends the command saying what to do."""
    from sqlalchemy.engine import make_url
    from sqlalchemy.exc import SQLAlchemyError

    from api.db import session_scope
    from api.settings import get_settings

    url = make_url(get_settings().sqlalchemy_url)
    if url.get_backend_name() == "sqlite" and url.database and not Path(url.database).is_file():
        raise _fail(f"no RigForge database at {url.database}: {WHERE} (`rigforge migrate` creates one)")
    try:
        with session_scope() as session:
            yield session
    except SQLAlchemyError as exc:
        cause = str(getattr(exc, "orig", None) or exc).splitlines()[0]
        raise _fail(f"cannot use the key store at {url.render_as_string(hide_password=True)}: {cause}; "
                    f"`rigforge migrate` brings its schema up to date, or {WHERE}") from None


@app.command("create")
def create(
    name: Annotated[str, typer.Option("--name", help="who or what uses this key")],
    admin: Annotated[bool, typer.Option("--admin", help="the key may list, create and revoke keys over HTTP")] = False,
) -> None:
    """Create a key and print it on stdout (it cannot be shown again)."""
    from api.keys.service import create_key

    with key_store() as session:
        _, secret = create_key(session, name=name, admin=admin)
    typer.echo(secret)


@app.command("list")
def list_() -> None:
    """List keys (prefix, name, admin, created, revoked)."""
    from api.keys.service import list_keys

    table = Table("id", "prefix", "name", "admin", "created", "revoked")
    with key_store() as session:
        for k in list_keys(session):
            table.add_row(str(k.id), k.prefix, k.name, "yes" if k.is_admin else "", k.created_at.isoformat(timespec="seconds"),
                          k.revoked_at.isoformat(timespec="seconds") if k.revoked_at else "")
    Console().print(table)


@app.command("revoke")
def revoke(key: Annotated[str, typer.Argument(help="key id or prefix")]) -> None:
    """Revoke a key by id or prefix."""
    from api.keys.service import revoke as revoke_key

    with key_store() as session:
        row = revoke_key(session, key_id_or_prefix=key)
    if row is None:
        typer.echo(f"no key {key}", err=True)
        raise typer.Exit(1)
    typer.echo(f"revoked {row.prefix} ({row.name})")
