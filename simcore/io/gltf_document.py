"""Strict glTF 2.0 container reader: GLB or embedded-buffer .gltf bytes → JSON + buffers + typed accessors.

Never follows a URI outside the upload: only the GLB BIN chunk and `data:` URIs are accepted for buffers;
images with any other URI are dropped unread (gltf_images), so the mesh goes through without those textures.
Every accessor read is bounds-checked against its buffer view and buffer, so a lying file raises InvalidInput
instead of reading garbage. This is "our own reader"; pygltflib and trimesh are the independent ones.
"""

from __future__ import annotations

import base64
import json
import struct
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from simcore.errors import InvalidInput, LimitExceeded, UnsupportedFormat
from simcore.io.gltf_draco import decompress_draco
from simcore.io.gltf_images import drop_external_images
from simcore.io.gltf_schema import node_parents, validate_structure

COMPONENT_DTYPES: dict[int, type[np.generic]] = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
TYPE_WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
MAX_ACCESSOR_ELEMENTS = 50_000_000
UNREADABLE_EXTENSIONS = {"EXT_meshopt_compression", "KHR_meshopt_compression"}  # no maintained Python decoder
GLB_MAGIC = b"glTF"


def _fail(message: str) -> InvalidInput:
    return InvalidInput(message, code="invalid_gltf", field="mesh")


def _decode_data_uri(uri: str) -> bytes:
    if not uri.startswith("data:"):
        raise InvalidInput(
            f"external URI {uri[:80]!r} refused: upload a GLB or a .gltf with embedded data: URIs",
            code="external_uri", field="mesh",
        )
    header, _, payload = uri.partition(",")
    if not header.endswith(";base64"):
        raise _fail("only base64 data: URIs are supported")
    try:
        return base64.b64decode(payload, validate=True)
    except ValueError as exc:
        raise _fail(f"data: URI is not valid base64: {exc}") from exc


def _split_glb(data: bytes) -> tuple[dict, bytes | None]:
    if len(data) < 20:
        raise _fail("GLB is truncated (shorter than its header)")
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    if magic != GLB_MAGIC or version != 2:
        raise _fail("not a glTF 2.0 binary (bad magic or version)")
    if length != len(data):
        raise _fail(f"GLB header says {length} bytes but the file has {len(data)} (truncated or padded)")
    offset, doc, binary = 12, None, None
    while offset + 8 <= len(data):
        chunk_len, chunk_type = struct.unpack_from("<I4s", data, offset)
        start, end = offset + 8, offset + 8 + chunk_len
        if end > len(data):
            raise _fail("GLB chunk runs past the end of the file")
        if chunk_type == b"JSON" and doc is None:
            doc = _parse_json(data[start:end])
        elif chunk_type == b"BIN\x00" and binary is None:
            binary = data[start:end]
        offset = end
    if doc is None:
        raise _fail("GLB has no JSON chunk")
    return doc, binary


def _parse_json(raw: bytes) -> dict:
    try:
        doc = json.loads(raw.decode("utf-8").rstrip(" \x00"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise _fail(f"glTF JSON does not parse: {exc}") from exc
    except RecursionError:
        raise LimitExceeded("the glTF JSON is nested too deeply", code="json_too_deep", field="mesh") from None
    if not isinstance(doc, dict) or not isinstance(doc.get("asset"), dict):
        raise _fail("glTF JSON has no 'asset' object")
    if str(doc["asset"].get("version", "")).split(".")[0] != "2":
        raise _fail("only glTF 2.0 is supported")
    return doc


def is_glb(data: bytes) -> bool:
    return data[:4] == GLB_MAGIC


@dataclass
class GltfDocument:
    """A parsed glTF: the JSON tree and its resolved buffers (bytes)."""

    json: dict
    buffers: list[bytes] = field(default_factory=list)
    dropped_images: list[str] = field(default_factory=list)  # external image URIs removed unread (gltf_images)

    @classmethod
    def from_bytes(cls, data: bytes, *, decode_draco: bool = True) -> GltfDocument:
        """Parse GLB or .gltf bytes; resolve buffers from the BIN chunk or data: URIs only.

        decode_draco: decode Draco-compressed primitives (the worker reads geometry); the API's upload check
        passes False, so decoding never runs in the API process.
        """
        doc, binary = _split_glb(data) if is_glb(data) else (_parse_json(data), None)
        required = doc.get("extensionsRequired")
        unreadable = sorted(UNREADABLE_EXTENSIONS.intersection(required)) if isinstance(required, list) else []
        if unreadable:
            raise UnsupportedFormat(f"the file requires {', '.join(unreadable)}, whose compressed geometry RigForge "
                                    "cannot decode; export it without that compression", field="mesh")
        validate_structure(doc)
        buffers: list[bytes] = []
        for i, buf in enumerate(doc.get("buffers", [])):
            if "uri" in buf:
                blob = _decode_data_uri(buf["uri"])
            elif i == 0 and binary is not None:
                blob = binary
            else:
                raise _fail(f"buffer {i} has no data")
            declared = buf["byteLength"]
            if declared > len(blob):
                raise _fail(f"buffer {i} declares {declared} bytes but holds {len(blob)}")
            buffers.append(blob[:declared])
        dropped = drop_external_images(doc)
        for image in doc.get("images", []):
            if "uri" in image:
                _decode_data_uri(image["uri"])
        document = cls(doc, buffers, dropped)
        if decode_draco:
            decompress_draco(document)
        return document

    def items(self, key: str) -> list[dict]:
        value = self.json.get(key, [])
        if not isinstance(value, list):
            raise _fail(f"'{key}' must be an array")
        return value

    def _item(self, key: str, index: int) -> dict:
        items = self.items(key)
        if not isinstance(index, int) or not 0 <= index < len(items):
            raise _fail(f"{key}[{index}] does not exist")
        return items[index]

    def view_bytes(self, view_index: int) -> tuple[bytes, int]:
        """(bytes of bufferView `view_index`, its byteStride or 0)."""
        view = self._item("bufferViews", view_index)
        buffer = self.buffers[view.get("buffer", 0)] if view.get("buffer", 0) < len(self.buffers) else None
        if buffer is None:
            raise _fail(f"bufferViews[{view_index}] points to a missing buffer")
        start, length = int(view.get("byteOffset", 0)), int(view["byteLength"])
        if start < 0 or length < 0 or start + length > len(buffer):
            raise _fail(f"bufferViews[{view_index}] runs past the end of its buffer")
        return buffer[start:start + length], int(view.get("byteStride", 0))

    def _read_strided(self, view_index: int, offset: int, count: int, dtype: np.dtype, width: int) -> np.ndarray:
        view, stride = self.view_bytes(view_index)
        element = dtype.itemsize * width
        stride = stride or element
        needed = offset + (count - 1) * stride + element if count else 0
        if offset < 0 or needed > len(view):
            raise _fail(f"accessor reads {needed} bytes from a {len(view)}-byte buffer view")
        if stride == element:
            return np.frombuffer(view, dtype, count * width, offset).reshape(count, width).copy()
        rows = np.lib.stride_tricks.as_strided(
            np.frombuffer(view, np.uint8, len(view) - offset, offset), (count, element), (stride, 1)
        )
        return rows.copy().view(dtype).reshape(count, width)

    def accessor(self, index: int) -> np.ndarray:
        """(count, width) array of accessor `index`; normalized integers become float32 in [0,1]/[-1,1]."""
        acc = self._item("accessors", index)
        try:
            dtype: np.dtype = np.dtype(COMPONENT_DTYPES[acc["componentType"]])
            width, count = TYPE_WIDTHS[acc["type"]], int(acc["count"])
        except KeyError as exc:
            raise _fail(f"accessors[{index}] has a bad type: {exc}") from exc
        if count < 0 or count * width > MAX_ACCESSOR_ELEMENTS:
            raise LimitExceeded(f"accessors[{index}] holds {count} elements, over the cap", field="mesh")
        if "bufferView" in acc:
            out = self._read_strided(acc["bufferView"], int(acc.get("byteOffset", 0)), count, dtype, width)
        else:
            out = np.zeros((count, width), dtype)
        sparse = acc.get("sparse")
        if sparse:
            n = int(sparse["count"])
            idx_dtype = np.dtype(COMPONENT_DTYPES[sparse["indices"]["componentType"]])
            idx = self._read_strided(sparse["indices"]["bufferView"], int(sparse["indices"].get("byteOffset", 0)), n, idx_dtype, 1)[:, 0]
            vals = self._read_strided(sparse["values"]["bufferView"], int(sparse["values"].get("byteOffset", 0)), n, dtype, width)
            if n and int(idx.max()) >= count:
                raise _fail(f"accessors[{index}] sparse index out of range")
            out = out.copy()
            out[idx.astype(np.int64)] = vals
        if acc.get("normalized") and dtype.kind in "ui":
            out = np.maximum(out.astype(np.float32) / np.iinfo(dtype).max, -1.0)
        return out

    def node_local_matrix(self, index: int) -> np.ndarray:
        """(4, 4) float64 column-vector local transform of node `index` (matrix or TRS; quaternions xyzw)."""
        node = self._item("nodes", index)
        if "matrix" in node:
            return np.asarray(node["matrix"], dtype=np.float64).reshape(4, 4).T
        m = np.eye(4)
        if "rotation" in node:
            m[:3, :3] = Rotation.from_quat(np.asarray(node["rotation"], dtype=np.float64)).as_matrix()
        if "scale" in node:
            m[:3, :3] = m[:3, :3] @ np.diag(np.asarray(node["scale"], dtype=np.float64))
        if "translation" in node:
            m[:3, 3] = node["translation"]
        return m

    def node_parents(self) -> np.ndarray:
        """(N,) int64 parent node of each node (-1 for scene roots); raises on cycles, shared children, depth."""
        return node_parents(self.items("nodes"))

    def world_matrices(self) -> np.ndarray:
        """(N, 4, 4) float64 world transform of every node at its rest (node TRS) pose."""
        parents = self.node_parents()
        out = np.zeros((len(parents), 4, 4))
        done = np.zeros(len(parents), bool)

        def resolve(i: int) -> np.ndarray:
            chain = []
            while i >= 0 and not done[i]:
                chain.append(i)
                i = int(parents[i])
            base = out[i] if i >= 0 else np.eye(4)
            for j in reversed(chain):
                base = base @ self.node_local_matrix(j)
                out[j], done[j] = base, True
            return base

        for i in range(len(parents)):
            resolve(i)
        return out
