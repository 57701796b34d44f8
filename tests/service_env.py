"""Point the service at a fresh data directory / database / broker and reset every cached singleton."""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


def reset_singletons() -> None:
    from api import changes
    from api.db import reset_caches
    from api.settings import get_settings
    from api.signed_urls import signing_key
    from api.storage import get_storage
    from worker.celery_app import make_celery

    get_settings.cache_clear()
    reset_caches()
    make_celery.cache_clear()
    get_storage.cache_clear()
    signing_key.cache_clear()
    changes.reset()  # stop listening to the previous service's notices; caches start empty


@contextmanager
def service_env(data_dir: Path, **overrides: str) -> Iterator[None]:
    """Environment for one test: RIGFORGE_DATA_DIR plus overrides (e.g. DATABASE_URL), migrated."""
    from api.migrate import upgrade_head

    env = {"RIGFORGE_DATA_DIR": str(data_dir), **{f"RIGFORGE_{k.upper()}": v for k, v in overrides.items()}}
    saved = {k: os.environ.get(k) for k in env}
    os.environ.update(env)
    reset_singletons()
    try:
        upgrade_head()
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
        reset_singletons()
