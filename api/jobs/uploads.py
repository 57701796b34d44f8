"""Turn multipart uploads into stored, sniffed, structurally checked files."""

from __future__ import annotations

import threading
from functools import lru_cache
from pathlib import Path

from fastapi import UploadFile

from api.errors import Problem
from api.settings import get_settings
from api.storage import Storage, StoredFile, UploadTooLarge
from simcore.errors import SimcoreError
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_zip import glb_from_zip
from simcore.io.sniff import require_kind, sniff

PARSE_WAIT_SECONDS = 5.0
RETRY_AFTER_SECONDS = 5


@lru_cache
def _parse_slots(count: int) -> threading.BoundedSemaphore:
    return threading.BoundedSemaphore(count)


def upload_format(head: bytes, size: int, *, kind: str, field: str) -> str:
    """The sniffed format of an upload, checked against `kind` ("mesh" or "motion"). Raises SimcoreError naming `field`."""
    try:
        return require_kind(sniff(head, size), kind, field)
    except SimcoreError as exc:
        exc.field = field
        raise


def check_structure(path: Path, fmt: str, *, field: str) -> None:
    """Parse a glTF upload's container and JSON (a .zip packed into one GLB first; structure, bounds, no external
    buffer URIs; Draco is left to the worker). A .zip that is a mesh sequence (per-frame OBJ/PLY files, a .usdz)
    and USD are read by the worker's sequence reader (simcore.motion_rig.upload), which checks them.

    At most `max_parallel_parses` run at once, since a big .gltf costs several times its size in memory;
    a request that finds no free slot within PARSE_WAIT_SECONDS is answered 503 with Retry-After.
    """
    if fmt not in ("glb", "gltf", "zip"):
        return
    slots = _parse_slots(get_settings().max_parallel_parses)
    if not slots.acquire(timeout=PARSE_WAIT_SECONDS):
        raise Problem(503, "server_busy", "too many uploads are being checked right now; retry shortly", field=field,
                      headers={"Retry-After": str(RETRY_AFTER_SECONDS)})
    try:
        data = path.read_bytes()
        from simcore.motion_rig.upload import is_sequence_archive  # imported on use (numpy)

        if fmt == "zip" and is_sequence_archive(data):
            return
        GltfDocument.from_bytes(glb_from_zip(data) if fmt == "zip" else data, decode_draco=False)
    except SimcoreError as exc:
        exc.field = field
        raise
    finally:
        slots.release()


def store_upload(storage: Storage, upload: UploadFile, *, kind: str, field: str, max_bytes: int) -> tuple[StoredFile, str, str]:
    """Stream `upload` into scratch space, check it, keep it; returns (stored file, original filename, format).
    Raises Problem/SimcoreError."""
    try:
        with storage.stage(upload.file, max_bytes) as staged:
            fmt = upload_format(staged.head, staged.size, kind=kind, field=field)
            check_structure(staged.path, fmt, field=field)
            return storage.keep(staged), upload.filename or field, fmt
    except UploadTooLarge:
        raise Problem(413, "upload_too_large", f"'{field}' is larger than {max_bytes // (1024 * 1024)} MB", field=field) from None


def store_skeleton(storage: Storage, upload: UploadFile, *, max_bytes: int) -> tuple[StoredFile, str, str]:
    """Store an edited skeleton.json and check it (simcore.skeleton.skeleton_file; the mesh bounds are checked by
    the worker); returns (stored file, original filename, "json"). Raises Problem/SimcoreError naming `skeleton`."""
    from simcore.skeleton.skeleton_file import MAX_FILE_BYTES, read_skeleton_file

    try:
        with storage.stage(upload.file, min(max_bytes, MAX_FILE_BYTES)) as staged:
            read_skeleton_file(staged.path.read_bytes())
            return storage.keep(staged), upload.filename or "skeleton.json", "json"
    except UploadTooLarge:
        raise Problem(413, "upload_too_large", f"'skeleton' is larger than {MAX_FILE_BYTES // 1024} KB",
                      field="skeleton") from None
