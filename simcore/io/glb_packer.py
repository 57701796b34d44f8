"""GLB assembly: a glTF JSON tree plus one binary buffer that new typed accessors are appended to.

The writer starts from an existing document (our ingested mesh.glb) and keeps its buffer 0 byte for
byte at the start of the new BIN chunk, so every original bufferView offset stays valid and the
original mesh data (indices, normals, UVs, embedded textures) is carried over untouched.
"""

from __future__ import annotations

import copy
import json
import struct

import numpy as np

ARRAY_BUFFER = 34962  # bufferView target of vertex attributes
ELEMENT_ARRAY_BUFFER = 34963  # bufferView target of triangle indices
COMPONENT_TYPES = {np.dtype(np.int8): 5120, np.dtype(np.uint8): 5121, np.dtype(np.int16): 5122,
                   np.dtype(np.uint16): 5123, np.dtype(np.uint32): 5125, np.dtype(np.float32): 5126}
TYPES_BY_WIDTH = {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4", 16: "MAT4"}


def _pad(data: bytes | bytearray, fill: bytes) -> bytes:
    return bytes(data) + fill * (-len(data) % 4)


class GlbBuilder:
    """Accumulates JSON and binary data; `to_glb()` returns the finished file.

    json:   the glTF tree being written (a deep copy of the starting document's JSON).
    binary: buffer 0's bytes; new data is appended 4-byte aligned.
    """

    def __init__(self, gltf_json: dict, buffer0: bytes = b"") -> None:
        self.json = copy.deepcopy(gltf_json)
        self.binary = bytearray(buffer0)
        self.json.setdefault("buffers", [])
        if not self.json["buffers"]:
            self.json["buffers"].append({"byteLength": 0})
        # GLB's BIN chunk is buffer 0 only when that buffer has no URI.
        self.json["buffers"][0].pop("uri", None)

    def _list(self, key: str) -> list:
        return self.json.setdefault(key, [])

    def add(self, key: str, item: dict) -> int:
        """Append `item` to the top-level array `key`; return its index."""
        items = self._list(key)
        items.append(item)
        return len(items) - 1

    def add_view(self, data: bytes, target: int | None = None) -> int:
        """Append raw bytes as a new bufferView of buffer 0 (4-byte aligned); return the view index."""
        self.binary.extend(b"\x00" * (-len(self.binary) % 4))
        view = {"buffer": 0, "byteOffset": len(self.binary), "byteLength": len(data)}
        if target is not None:
            view["target"] = target
        self.binary.extend(data)
        return self.add("bufferViews", view)

    def add_accessor(self, array: np.ndarray, *, target: int | None = None, minmax: bool = False,
                     normalized: bool = False) -> int:
        """Append a (count, width) or (count,) array as an accessor in its own bufferView.

        array:  numeric array whose dtype is one of glTF's component types (float32, uint8, uint16...);
                width 1, 2, 3, 4 or 16 (MAT4, given column-major per row as glTF stores it).
        minmax: write per-component min/max (required for POSITION and animation input).
        """
        arr = np.ascontiguousarray(array)
        arr2 = arr.reshape(len(arr), -1)
        if arr.dtype not in COMPONENT_TYPES or arr2.shape[1] not in TYPES_BY_WIDTH:
            raise ValueError(f"cannot store a {arr.dtype} array of shape {arr.shape} as an accessor")
        accessor: dict = {
            "bufferView": self.add_view(arr2.tobytes(), target),
            "componentType": COMPONENT_TYPES[arr.dtype],
            "count": int(arr2.shape[0]),
            "type": TYPES_BY_WIDTH[arr2.shape[1]],
        }
        if normalized:
            accessor["normalized"] = True
        if minmax and len(arr2):
            cast = float if arr.dtype.kind == "f" else int
            accessor["min"] = [cast(v) for v in arr2.min(axis=0)]
            accessor["max"] = [cast(v) for v in arr2.max(axis=0)]
        return self.add("accessors", accessor)

    def to_glb(self) -> bytes:
        """Serialise: 12-byte header, JSON chunk padded with spaces, BIN chunk padded with zeros."""
        self.json["buffers"][0]["byteLength"] = len(self.binary)
        body = json.dumps(self.json, separators=(",", ":"), ensure_ascii=False).encode("utf-8")
        json_chunk = _pad(body, b" ")
        chunks = struct.pack("<I4s", len(json_chunk), b"JSON") + json_chunk
        if self.binary:
            bin_chunk = _pad(self.binary, b"\x00")
            chunks += struct.pack("<I4s", len(bin_chunk), b"BIN\x00") + bin_chunk
        return struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks
