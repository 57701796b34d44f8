"""`rigforge serve | worker | migrate`: run the service on the embedded default or scaled out."""

from __future__ import annotations

import os
import signal
import sys
from typing import Annotated

import typer

from api.settings import get_settings


def migrate() -> None:
    """Bring the database schema to the newest revision."""
    from api.migrate import upgrade_head

    upgrade_head()
    typer.echo(f"database at head: {get_settings().sqlalchemy_url.split('@')[-1]}")


def ensure_local_key() -> str | None:
    """On a fresh embedded install, create a 'local' admin key and keep it in data_dir/local-api-key (mode 600)."""
    from api.db import session_scope
    from api.keys.service import create_key, list_keys

    settings = get_settings()
    path = settings.local_key_file
    if path.exists():
        return path.read_text().strip()
    with session_scope() as session:
        if list_keys(session):
            return None
        _, secret = create_key(session, name="local", admin=True)
    path.write_text(secret + "\n")
    path.chmod(0o600)
    return secret


def worker(
    concurrency: Annotated[int, typer.Option(help="parallel jobs in this worker")] = 1,
    loglevel: Annotated[str, typer.Option(help="celery log level")] = "INFO",
    queues: Annotated[str, typer.Option(help="queues to consume, comma-separated: 'cpu', 'gpu' (refinement and "
                                            "learned models, routed there while such a worker runs) or both")] = "cpu,gpu",
) -> None:
    """Run a Celery worker (with the reconciler) for the configured broker."""
    from worker.celery_app import make_celery
    from worker.routing import QUEUES

    names = [q.strip() for q in queues.split(",") if q.strip()]
    if not names or set(names) - set(QUEUES):
        raise typer.BadParameter(f"queues are {', '.join(QUEUES)}; got {queues!r}", param_hint="--queues")
    make_celery().worker_main([
        "worker", f"--loglevel={loglevel}", f"--concurrency={concurrency}", "--pool=prefork", "-Q", ",".join(names),
        "--without-gossip", "--without-mingle", "--without-heartbeat", "--hostname", f"rigforge-{os.getpid()}@%h",
    ])


def serve(
    host: Annotated[str | None, typer.Option(help="bind address (default RIGFORGE_HOST or 127.0.0.1)")] = None,
    port: Annotated[int | None, typer.Option(help="port (default RIGFORGE_PORT or 8000)")] = None,
    no_worker: Annotated[bool, typer.Option("--no-worker", help="API only (workers run elsewhere)")] = False,
    migrate_first: Annotated[bool, typer.Option("--migrate/--no-migrate", help="bring the database to head first (scaled out, "
                                                "one `rigforge migrate` does it before any replica starts)")] = True,
) -> None:
    """Migrate, then serve the API and dashboard, with one embedded worker unless --no-worker."""
    import uvicorn

    from api.log_format import log_config

    settings = get_settings()
    if migrate_first:
        migrate()
    secret = ensure_local_key() if settings.env == "development" else None  # production: `rigforge keys create --admin`
    if secret:
        typer.echo(f"local API key (also in {settings.local_key_file}): {secret}")
    embedded = None
    if not no_worker:
        from worker.embedded import EmbeddedWorker

        embedded = EmbeddedWorker(settings)
        embedded.start()
    # uvicorn re-raises SIGTERM after its shutdown with our handler restored: exit through `finally`.
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))
    try:
        uvicorn.run("api.app:create_app", factory=True, host=host or settings.host, port=port or settings.port,
                    log_level="info", log_config=log_config(settings), timeout_graceful_shutdown=5)
    except KeyboardInterrupt:  # Ctrl-C: uvicorn re-raises SIGINT after its graceful shutdown
        pass
    finally:
        if embedded is not None:
            embedded.stop()
