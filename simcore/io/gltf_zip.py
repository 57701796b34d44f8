"""A glTF uploaded as a .zip (the .gltf, its .bin buffers and its images) → one self-contained GLB.

The archive is read in memory, never extracted. Limits: at most MAX_ENTRIES entries and MAX_UNPACKED_BYTES
unpacked in all (zipfile stops each entry at its declared size, so a lying header cannot inflate more). Every
entry name and every URI the .gltf uses must stay inside the archive: absolute paths, drive letters, schemes
and `..` that climb out of it are refused (code zip_unsafe_path) for entries and buffers. Buffers must be in
the archive; an image it does not hold (or whose URI leads outside it) keeps its URI, so GltfDocument drops it
unread with the external-image warning.
"""

from __future__ import annotations

import base64
import binascii
import io
import json
import posixpath
import re
import zipfile
from urllib.parse import unquote

from simcore.errors import InvalidInput, LimitExceeded
from simcore.io.glb_packer import GlbBuilder

ZIP_MAGIC = b"PK\x03\x04"
MAX_ENTRIES = 1000
MAX_UNPACKED_BYTES = 512 * 1024 * 1024
IMAGE_TYPES = {".png": "image/png", ".jpg": "image/jpeg", ".jpeg": "image/jpeg", ".webp": "image/webp",
               ".ktx2": "image/ktx2"}
_DRIVE_OR_SCHEME = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*:")


def is_zip(data: bytes) -> bool:
    return data[:4] == ZIP_MAGIC


def _fail(message: str, code: str) -> InvalidInput:
    return InvalidInput(message, code=code, field="mesh")


def _inside(path: str, what: str) -> str:
    """`path` (forward slashes) normalised; refused when it is absolute, has a drive or scheme, or climbs out."""
    path = path.replace("\\", "/")
    normal = posixpath.normpath(path) if path else ""
    if path.startswith("/") or _DRIVE_OR_SCHEME.match(path) or normal == ".." or normal.startswith("../"):
        raise _fail(f"{what} {path[:120]!r} points outside the archive", "zip_unsafe_path")
    return normal


class ZipArchive:
    """The archive's files by normalised name, read on demand within the caps."""

    def __init__(self, data: bytes) -> None:
        try:
            self.zip = zipfile.ZipFile(io.BytesIO(data))
            infos = self.zip.infolist()
        except (zipfile.BadZipFile, zipfile.LargeZipFile, ValueError) as exc:
            raise _fail(f"the .zip cannot be read: {exc}", "invalid_zip") from exc
        if len(infos) > MAX_ENTRIES:
            raise LimitExceeded(f"the .zip has {len(infos)} entries; the limit is {MAX_ENTRIES}",
                                code="zip_too_many_entries", field="mesh")
        unpacked = sum(i.file_size for i in infos)
        if unpacked > MAX_UNPACKED_BYTES:
            raise LimitExceeded(f"the .zip unpacks to {unpacked} bytes; the limit is {MAX_UNPACKED_BYTES}",
                                code="zip_too_large", field="mesh")
        self.files = {_inside(i.filename, "entry"): i for i in infos if not i.is_dir()}

    def read(self, name: str) -> bytes:
        try:
            return self.zip.read(self.files[name])
        except (zipfile.BadZipFile, RuntimeError, ValueError, EOFError) as exc:  # corrupt, encrypted, truncated
            raise _fail(f"{name!r} in the .zip cannot be read: {exc}", "invalid_zip") from exc


def _uri_path(base: str, uri: str) -> str:
    """The archive name a relative glTF URI (percent-encoded, relative to the .gltf's folder) refers to."""
    _inside(unquote(uri), "URI")
    return _inside(posixpath.join(base, unquote(uri)), "URI")


def _data_uri(uri: str) -> bytes:
    header, _, payload = uri.partition(",")
    if not header.endswith(";base64"):
        raise _fail("only base64 data: URIs are supported", "invalid_gltf")
    try:
        return base64.b64decode(payload, validate=True)
    except binascii.Error as exc:
        raise _fail(f"data: URI is not valid base64: {exc}", "invalid_gltf") from exc


def _the_model(archive: ZipArchive) -> str:
    models = sorted(n for n in archive.files if n.lower().endswith((".gltf", ".glb")))
    if len(models) != 1:
        found = ", ".join(models[:5]) or "none"
        raise _fail(f"a .zip upload must hold exactly one .gltf (or .glb); found {found}",
                    "zip_no_gltf" if not models else "zip_several_models")
    return models[0]


def glb_from_zip(data: bytes) -> bytes:
    """GLB bytes of the one .gltf in the .zip `data` with its buffers and the images the archive holds packed
    into the BIN chunk (a .glb in the archive is returned as it is). Raises InvalidInput / LimitExceeded."""
    archive = ZipArchive(data)
    model = _the_model(archive)
    if model.lower().endswith(".glb"):
        return archive.read(model)
    try:
        doc = json.loads(archive.read(model).decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise _fail(f"{model!r} does not parse as JSON: {exc}", "invalid_gltf") from exc
    if not isinstance(doc, dict) or not isinstance(doc.get("buffers", []), list):
        raise _fail(f"{model!r} is not a glTF document", "invalid_gltf")
    base = posixpath.dirname(model)
    builder = GlbBuilder({k: v for k, v in doc.items() if k != "buffers"})
    offsets = []
    for i, buf in enumerate(doc.get("buffers", [])):
        uri = buf.get("uri") if isinstance(buf, dict) else None
        if not isinstance(uri, str):
            raise _fail(f"buffer {i} has no uri", "invalid_gltf")
        if uri.startswith("data:"):
            blob = _data_uri(uri)
        else:
            name = _uri_path(base, uri)
            if name not in archive.files:
                raise _fail(f"buffer {i} is {uri[:120]!r}, which the .zip does not hold", "zip_missing_file")
            blob = archive.read(name)
        builder.binary.extend(b"\x00" * (-len(builder.binary) % 4))
        offsets.append(len(builder.binary))
        builder.binary.extend(blob)
    for k, view in enumerate(builder.json.get("bufferViews", [])):
        b = view.get("buffer") if isinstance(view, dict) else None
        if not isinstance(b, int) or not 0 <= b < len(offsets):
            raise _fail(f"bufferViews[{k}] points to a missing buffer", "invalid_gltf")
        view["buffer"], view["byteOffset"] = 0, offsets[b] + int(view.get("byteOffset", 0))
    for image in builder.json.get("images", []):
        uri = image.get("uri") if isinstance(image, dict) else None
        if not isinstance(uri, str) or uri.startswith("data:"):
            continue
        try:
            name = _uri_path(base, uri)
        except InvalidInput:  # outside the archive: left for GltfDocument to drop unread, like any external image
            continue
        if name in archive.files:
            image.pop("uri")
            image["bufferView"] = builder.add_view(archive.read(name))
            image.setdefault("mimeType", IMAGE_TYPES.get(posixpath.splitext(name)[1].lower(), "image/png"))
    return builder.to_glb()
