"""Write the API's OpenAPI document for the dashboard's typed client (it types what it submits with JobOptions).

Usage: python web/dump_openapi.py web/openapi.json
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
from pathlib import Path


def openapi_document() -> dict:
    """The spec of `api.app.create_app()` built against a throwaway data directory."""
    from api.settings import get_settings

    saved, saved_tempdir = os.environ.get("RIGFORGE_DATA_DIR"), tempfile.tempdir
    with tempfile.TemporaryDirectory(prefix="rigforge-openapi-") as tmp:
        os.environ["RIGFORGE_DATA_DIR"] = tmp  # create_app makes its data dir; keep the checkout clean
        get_settings.cache_clear()
        try:
            from api.app import create_app

            spec = create_app().openapi()
        finally:
            if saved is None:
                os.environ.pop("RIGFORGE_DATA_DIR", None)
            else:
                os.environ["RIGFORGE_DATA_DIR"] = saved
            get_settings.cache_clear()
            tempfile.tempdir = saved_tempdir  # create_app points multipart spooling into the data dir
    return spec


def main() -> None:
    out = Path(sys.argv[1] if len(sys.argv) > 1 else Path(__file__).with_name("openapi.json"))
    out.write_text(json.dumps(openapi_document(), indent=1, sort_keys=True) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from anywhere in the checkout
    main()
