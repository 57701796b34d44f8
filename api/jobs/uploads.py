"""Turn multipart uploads into stored, sniffed, structurally checked files."""

from __future__ import annotations

from fastapi import UploadFile

from api.errors import Problem
from api.storage import LocalStorage, StoredFile, UploadTooLarge
from simcore.errors import SimcoreError
from simcore.io.gltf_document import GltfDocument
from simcore.io.sniff import require_kind, sniff


def store_upload(storage: LocalStorage, upload: UploadFile, *, kind: str, field: str, max_bytes: int) -> tuple[StoredFile, str, str]:
    """Stream `upload` into storage; returns (stored file, original filename, format). Raises Problem/SimcoreError."""
    try:
        stored = storage.save_stream(upload.file, max_bytes)
    except UploadTooLarge:
        raise Problem(413, "upload_too_large", f"'{field}' is larger than {max_bytes // (1024 * 1024)} MB", field=field) from None
    try:
        fmt = require_kind(sniff(stored.head, stored.size), kind, field)
        if fmt in ("glb", "gltf"):
            GltfDocument.from_bytes(stored.path.read_bytes(), decode_draco=False)  # structure, bounds, no external URIs
    except SimcoreError as exc:
        exc.field = field
        raise
    return stored, upload.filename or field, fmt
