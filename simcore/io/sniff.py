"""Recognise an upload's real format from its first bytes (never from its name)."""

from __future__ import annotations

import re
import struct

from simcore.errors import InvalidInput, UnsupportedFormat

MESH_FORMATS = ("glb", "gltf", "zip", "obj", "ply", "stl", "usd")  # zip: a .gltf with its .bin and images
# (or a mesh sequence: per-frame OBJ/PLY, a .usdz); usd: a mesh sequence (time-sampled points)
MOTION_FORMATS = ("bvh", "glb", "gltf")
MEDIA_TYPES = {
    "glb": "model/gltf-binary", "gltf": "model/gltf+json", "obj": "model/obj", "ply": "application/ply",
    "stl": "model/stl", "usd": "model/vnd.usd", "bvh": "application/x-bvh", "fbx": "application/octet-stream", "zip": "application/zip",
}
GLTF_KEYS = (b'"asset"', b'"accessors"', b'"bufferViews"', b'"buffers"', b'"meshes"', b'"nodes"', b'"scenes"')
_OBJ_LINE = re.compile(rb"^\s*(v|vt|vn|f|o|g|s|usemtl|mtllib|#)(\s|$)")


def _looks_like_obj(head: bytes) -> bool:
    lines = [ln for ln in head.splitlines()[:200] if ln.strip()]
    if not lines or not all(_OBJ_LINE.match(ln) for ln in lines[:-1]):
        return False
    return any(ln.lstrip().startswith(b"v ") for ln in lines)


def sniff(head: bytes, size: int) -> str:
    """Format name of a file from its first bytes (`head`, ≥ 4 KiB when the file is that long) and size.

    Returns one of glb, gltf, zip, obj, ply, stl, usd (.usda text or .usdc crate), bvh, fbx; raises InvalidInput
    for anything else.
    """
    if size == 0:
        raise InvalidInput("the file is empty", code="empty_file")
    if head[:4] == b"glTF":
        return "glb"
    if head[:4] == b"PK\x03\x04":
        return "zip"
    if head.startswith(b"Kaydara FBX Binary") or head.lstrip().startswith(b"; FBX"):
        return "fbx"
    if head[:8] == b"PXR-USDC" or head[:5] == b"#usda":
        return "usd"
    if head[:4] == b"ply\n" or head[:5] == b"ply\r\n":
        return "ply"
    if head.lstrip()[:9].upper() == b"HIERARCHY":
        return "bvh"
    stripped = head.lstrip()
    if stripped[:1] == b"{" and any(key in head for key in GLTF_KEYS):  # JSON keys come in any order
        return "gltf"
    if len(head) >= 84:
        (count,) = struct.unpack_from("<I", head, 80)
        if 84 + 50 * count == size and count > 0:
            return "stl"
    if stripped[:5].lower() == b"solid" and b"facet" in head:
        return "stl"
    if _looks_like_obj(head):
        return "obj"
    raise InvalidInput("unrecognised file format (expected GLB, glTF, a .zip of a glTF, OBJ, PLY, STL, USD or BVH)",
                       code="unknown_format")


def require_kind(fmt: str, kind: str, field: str) -> str:
    """Check a sniffed format is acceptable for `kind` ("mesh" or "motion"); FBX gets a clear 415."""
    if fmt == "fbx":
        raise UnsupportedFormat(
            "FBX is not supported yet: export GLB/glTF from your DCC tool (Blender, Maya: glTF exporter)",
            code="unsupported_format", field=field,
        )
    allowed = MESH_FORMATS if kind == "mesh" else MOTION_FORMATS
    if fmt not in allowed:
        raise InvalidInput(f"a {fmt.upper()} file is not a valid {kind} (expected {', '.join(allowed)})", code="wrong_kind", field=field)
    return fmt
