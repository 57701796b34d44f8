"""`rigforge keys create | list | revoke`: manage API keys (only hashes are stored)."""

from __future__ import annotations

from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

app = typer.Typer(help="Manage API keys.", no_args_is_help=True)


@app.command("create")
def create(
    name: Annotated[str, typer.Option("--name", help="who or what uses this key")],
    admin: Annotated[bool, typer.Option("--admin", help="the key may list, create and revoke keys over HTTP")] = False,
) -> None:
    """Create a key and print it on stdout (it cannot be shown again)."""
    from api.db import session_scope
    from api.keys.service import create_key

    with session_scope() as session:
        _, secret = create_key(session, name=name, admin=admin)
    typer.echo(secret)


@app.command("list")
def list_() -> None:
    """List keys (prefix, name, admin, created, revoked)."""
    from api.db import session_scope
    from api.keys.service import list_keys

    table = Table("id", "prefix", "name", "admin", "created", "revoked")
    with session_scope() as session:
        for k in list_keys(session):
            table.add_row(str(k.id), k.prefix, k.name, "yes" if k.is_admin else "", k.created_at.isoformat(timespec="seconds"),
                          k.revoked_at.isoformat(timespec="seconds") if k.revoked_at else "")
    Console().print(table)


@app.command("revoke")
def revoke(key: Annotated[str, typer.Argument(help="key id or prefix")]) -> None:
    """Revoke a key by id or prefix."""
    from api.db import session_scope
    from api.keys.service import revoke as revoke_key

    with session_scope() as session:
        row = revoke_key(session, key_id_or_prefix=key)
    if row is None:
        typer.echo(f"no key {key}", err=True)
        raise typer.Exit(1)
    typer.echo(f"revoked {row.prefix} ({row.name})")
