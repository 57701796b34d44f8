"""The API fixtures (SQLite in a temp dir, jobs run inline) for the requests of the corpus."""

from tests.api.conftest import auth, client, data_dir, inline_worker, storage_backend, storage_settings  # noqa: F401 - fixtures
