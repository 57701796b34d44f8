"""Shared fixtures: the dev assets in ../shared (skipped with a reason when absent)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
DEV_ASSETS = Path(os.environ.get("RIGFORGE_DEV_ASSETS", REPO.parent / "shared" / "assets" / "dev"))


@pytest.fixture(scope="session")
def dev_assets() -> Path:
    """Directory of the shared dev assets; skips the test when ../shared is not beside the repo."""
    if not (DEV_ASSETS / "MANIFEST.tsv").exists():
        pytest.skip(f"dev assets not found at {DEV_ASSETS} (set RIGFORGE_DEV_ASSETS)")
    return DEV_ASSETS
