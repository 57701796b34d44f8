"""Hostile glTF and GLB uploads: wrong JSON types, lying sizes and indices, cycles, depth and size bombs."""

from __future__ import annotations

import base64
import copy
import json
import struct
from collections.abc import Iterator

import numpy as np

from tests.hostile.case import OK, Case, case

BAD_GLTF = ("invalid_gltf",)
TRI = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)


def glb(doc: dict, binary: bytes = b"", declared_total: int | None = None) -> bytes:
    """A GLB container around `doc` (JSON chunk) and `binary` (BIN chunk), both padded to 4 bytes; `declared_total`
    overrides the header's length (a lying header)."""
    body = json.dumps(doc).encode()
    body += b" " * (-len(body) % 4)
    chunks = struct.pack("<I4s", len(body), b"JSON") + body
    if binary:
        binary += b"\0" * (-len(binary) % 4)
        chunks += struct.pack("<I4s", len(binary), b"BIN\0") + binary
    return struct.pack("<4sII", b"glTF", 2, declared_total or 12 + len(chunks)) + chunks


def embedded(doc: dict, binary: bytes) -> bytes:
    """A .gltf whose buffer 0 is a base64 data: URI."""
    doc = copy.deepcopy(doc)
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(binary).decode()
    return json.dumps(doc).encode()


def rigged_base() -> tuple[dict, bytes]:
    """A valid skinned, animated triangle: 2 joints, JOINTS_0/WEIGHTS_0, inverse binds, one translation clip."""
    joints = np.array([[0, 1, 0, 0]] * 3, np.uint8)
    weights = np.array([[0.5, 0.5, 0, 0]] * 3, np.float32)
    ibm = np.tile(np.eye(4, dtype=np.float32), (2, 1, 1))
    times = np.array([0.0, 1.0], np.float32)
    moves = np.array([[0, 0, 0], [0, 0.1, 0]], np.float32)
    indices = np.array([0, 1, 2, 0], np.uint16)
    blobs = [TRI.tobytes(), joints.tobytes(), weights.tobytes(), ibm.tobytes(), times.tobytes(), moves.tobytes(), indices.tobytes()]
    views, offset = [], 0
    for blob in blobs:
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(blob)})
        offset += len(blob)
    doc = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0, "skin": 0}, {"name": "root", "children": [2]}, {"name": "tip", "translation": [0, 1, 0],
                                                                                "rotation": [0, 0, 0, 1], "scale": [1, 1, 1]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "JOINTS_0": 1, "WEIGHTS_0": 2}, "indices": 6, "mode": 4}]}],
        "skins": [{"joints": [1, 2], "inverseBindMatrices": 3}],
        "animations": [{"name": "lift", "channels": [{"sampler": 0, "target": {"node": 2, "path": "translation"}}],
                        "samplers": [{"input": 4, "output": 5, "interpolation": "LINEAR"}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5121, "count": 3, "type": "VEC4"},
            {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC4"},
            {"bufferView": 3, "componentType": 5126, "count": 2, "type": "MAT4"},
            {"bufferView": 4, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [0], "max": [1]},
            {"bufferView": 5, "componentType": 5126, "count": 2, "type": "VEC3"},
            {"bufferView": 6, "componentType": 5123, "count": 3, "type": "SCALAR"},
        ],
        "bufferViews": views, "buffers": [{"byteLength": offset}],
    }
    return doc, b"".join(blobs)


# (JSON path inside the rigged base, values of the wrong type or out of range for it)
INDEX_BAD = [-1, 99, "0", 1.5, None, True, [0]]
COUNT_BAD = [-1, "3", 2.5, None, {}]
LIST_BAD = [5, "x", {}, None]
PROPERTY_MUTATIONS: list[tuple[tuple, list]] = [
    (("scene",), INDEX_BAD),
    (("scenes", 0, "nodes"), LIST_BAD + [[7], [-1], ["a"]]),
    (("nodes", 0, "mesh"), INDEX_BAD),
    (("nodes", 0, "skin"), INDEX_BAD),
    (("nodes", 1, "children"), LIST_BAD + [[1], [0, 0], [2, 2], [99], ["2"]]),
    (("nodes", 2, "translation"), [[0, 1], ["a", 0, 0], 5, [0, 0, None], [1e400, 0, 0]]),
    (("nodes", 2, "rotation"), [[0, 0, 0, 0], [0, 0, 1], "q", [None] * 4]),
    (("nodes", 2, "scale"), [[1, 1], 2, [1, 1, "1"]]),
    (("nodes", 2, "matrix"), [[1] * 15, "m", [[1, 0, 0, 0]] * 4]),
    (("meshes", 0, "primitives"), LIST_BAD + [[]]),
    (("meshes", 0, "primitives", 0), [5, "p", None, []]),
    (("meshes", 0, "primitives", 0, "attributes"), [5, [], "a", None]),
    (("meshes", 0, "primitives", 0, "attributes", "POSITION"), INDEX_BAD),
    (("meshes", 0, "primitives", 0, "indices"), INDEX_BAD),
    (("meshes", 0, "primitives", 0, "mode"), [-1, 7, "4", 4.5, None]),
    (("meshes", 0, "primitives", 0, "targets"), [5, [5], [{"POSITION": 99}]]),
    (("accessors", 0, "count"), COUNT_BAD + [10**12]),
    (("accessors", 0, "componentType"), [0, "5126", 5127, None, 5126.5]),
    (("accessors", 0, "type"), ["VEC5", 3, None, "vec3"]),
    (("accessors", 0, "bufferView"), INDEX_BAD),
    (("accessors", 0, "byteOffset"), [-4, "0", 1.5, 10**9]),
    (("accessors", 0, "sparse"), [5, {"count": 1}, {"count": 1, "indices": {"bufferView": 6, "componentType": 5123},
                                                    "values": {"bufferView": 99}}]),
    (("accessors", 6, "count"), [10**6, 4]),
    (("bufferViews", 0, "buffer"), INDEX_BAD),
    (("bufferViews", 0, "byteLength"), COUNT_BAD + [10**9]),
    (("bufferViews", 0, "byteOffset"), [-1, "0", 10**9]),
    (("bufferViews", 0, "byteStride"), [1, 253, "12", 3.5]),
    (("buffers", 0, "byteLength"), COUNT_BAD + [10**9]),
    (("skins", 0, "joints"), LIST_BAD + [[], [99], [-1]]),
    (("skins", 0, "inverseBindMatrices"), INDEX_BAD),
    (("animations", 0, "channels"), LIST_BAD + [[]]),
    (("animations", 0, "channels", 0, "sampler"), [-1, 5, "0", None]),
    (("animations", 0, "channels", 0, "target"), [5, {}, {"node": 99, "path": "translation"}, {"node": 2, "path": "color"}]),
    (("animations", 0, "samplers", 0, "interpolation"), ["CUBIC", 5]),
    (("animations", 0, "samplers", 0, "input"), INDEX_BAD),
    (("extensionsRequired",), [5, [5], "KHR_x"]),
]
TOP_LEVEL = ("buffers", "bufferViews", "accessors", "meshes", "nodes", "scenes", "skins", "animations", "images",
             "materials", "textures", "samplers")
MISSING = [("buffers", 0, "byteLength"), ("bufferViews", 0, "byteLength"), ("bufferViews", 0, "buffer"),
           ("accessors", 0, "count"), ("accessors", 0, "type"), ("accessors", 0, "componentType"),
           ("meshes", 0, "primitives"), ("meshes", 0, "primitives", 0, "attributes"), ("skins", 0, "joints"),
           ("animations", 0, "samplers"), ("animations", 0, "channels", 0, "target")]


def _set(doc: dict, path: tuple, value: object) -> dict:
    out = copy.deepcopy(doc)
    target = out
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = value
    return out


def _drop(doc: dict, path: tuple) -> dict:
    out = copy.deepcopy(doc)
    target = out
    for key in path[:-1]:
        target = target[key]
    del target[path[-1]]
    return out


def _label(path: tuple) -> str:
    return ".".join(str(p) for p in path)


def _mutations(doc: dict, binary: bytes) -> Iterator[Case]:
    for path, values in PROPERTY_MUTATIONS:
        for k, value in enumerate(values):
            expect = ("invalid_gltf", "unsupported_format", "limit_exceeded", "hierarchy_too_deep")
            yield case(f"gltf-{_label(path)}-bad{k}", "mesh", glb(_set(doc, path, value), binary), *expect)
    for key in TOP_LEVEL:
        for k, value in enumerate([5, "x", {}, None, [5], [None]]):
            yield case(f"gltf-top-{key}-bad{k}", "mesh", embedded(_set(doc, (key,), value), binary) if key != "buffers"
                       else json.dumps(_set(doc, (key,), value)).encode(), *BAD_GLTF)
    for path in MISSING:
        yield case(f"gltf-missing-{_label(path)}", "mesh", glb(_drop(doc, path), binary), *BAD_GLTF)


def _chain(depth: int) -> bytes:
    """A triangle under a `depth`-deep chain of nodes (the 20,000-deep chain took 190 s to check when quadratic)."""
    doc, binary = rigged_base()
    nodes = [{"children": [i + 1]} for i in range(depth - 1)] + [{"mesh": 0}]
    doc = {**doc, "nodes": nodes, "scenes": [{"nodes": [0]}]}
    doc["meshes"] = [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 6}]}]
    for key in ("skins", "animations"):
        doc.pop(key)
    return glb(doc, binary)


def _nested(depth: int) -> bytes:
    return b'{"asset": {"version": "2.0"}, "extras": ' + b"[" * depth + b"]" * depth + b"}"


def _containers(doc: dict, binary: bytes) -> Iterator[Case]:
    good = glb(doc, binary)
    yield case("glb-valid-rigged", "mesh", good, OK)
    yield case("gltf-valid-embedded", "mesh", embedded(doc, binary), OK)
    for n in (12, 19, 40, len(good) // 2, len(good) - 4):
        yield case(f"glb-truncated-{n}", "mesh", good[:n], "invalid_gltf", "unknown_format")
    yield case("glb-length-lies", "mesh", good[:8] + struct.pack("<I", len(good) + 100) + good[12:], *BAD_GLTF)
    yield case("glb-version-1", "mesh", good[:4] + struct.pack("<I", 1) + good[8:], *BAD_GLTF)
    yield case("glb-chunk-overrun", "mesh", good[:12] + struct.pack("<I", 10**6) + good[16:], *BAD_GLTF)
    yield case("glb-no-json-chunk", "mesh", struct.pack("<4sII", b"glTF", 2, 20) + struct.pack("<I4s", 0, b"BIN\0"), *BAD_GLTF)
    yield case("glb-no-bin-chunk", "mesh", glb(doc), *BAD_GLTF)
    for k, body in enumerate([b"[]", b'"glTF"', b"5", b"{}", b'{"asset": 5}', b'{"asset": {"version": "1.0"}}',
                              b'{"asset": {"version": "2.0"}, "nodes": [', b'\xff\xfe{"asset"}']):
        yield case(f"glb-json-{k}", "mesh", _raw_glb(body), *BAD_GLTF)
    yield case("gltf-no-meshes", "mesh", json.dumps({"asset": {"version": "2.0"}, "nodes": [{}], "scenes": [{"nodes": [0]}]}).encode(),
               "empty_mesh")
    yield case("gltf-points-only", "mesh", glb(_set(doc, ("meshes", 0, "primitives", 0, "mode"), 0), binary), "empty_mesh")
    for depth in (1025, 20_000):
        yield case(f"glb-node-chain-{depth}", "mesh", _chain(depth), "hierarchy_too_deep")
    yield case("glb-node-chain-1000", "mesh", _chain(1000), OK)
    yield case("glb-node-cycle-2", "mesh", glb(_set(doc, ("nodes", 2, "children"), [1]), binary), *BAD_GLTF)
    yield case("glb-node-self-child", "mesh", glb(_set(doc, ("nodes", 2, "children"), [2]), binary), *BAD_GLTF)
    yield case("glb-node-shared-child", "mesh", glb(_set(doc, ("nodes", 0, "children"), [2]), binary), *BAD_GLTF)
    for depth in (65, 1000, 100_000):
        yield case(f"gltf-nested-extras-{depth}", "mesh", _nested(depth), "json_too_deep")
    for k, uri in enumerate(["../../etc/passwd", "/etc/passwd", "file:///etc/passwd", "http://127.0.0.1:8000/healthz",
                             "data:application/octet-stream,AAAA", "data:;base64,!!!!", "C:\\windows\\win.ini"]):
        codes = ("external_uri", "invalid_gltf")
        yield case(f"gltf-buffer-uri-{k}", "mesh", json.dumps(_set(doc, ("buffers", 0, "uri"), uri)).encode(), *codes)
        yield case(f"gltf-image-uri-{k}", "mesh", embedded({**doc, "images": [{"uri": uri}]}, binary), OK, *codes)  # dropped unread
    yield case("gltf-ext-required-unknown", "mesh", glb({**doc, "extensionsRequired": ["VENDOR_magic"]}, binary), "unsupported_format")
    yield case("gltf-ext-required-meshopt", "mesh", glb({**doc, "extensionsRequired": ["EXT_meshopt_compression"]}, binary),
               "unsupported_format")
    nan = np.frombuffer(binary, np.uint8).copy()
    nan[:4] = np.frombuffer(np.float32(np.nan).tobytes(), np.uint8)
    yield case("glb-nan-position", "mesh", glb(doc, nan.tobytes()), "non_finite")
    huge = _set(doc, ("accessors", 0, "count"), 20_000_000)
    yield case("glb-accessor-count-over-cap", "mesh", glb(huge, binary), "limit_exceeded", "invalid_gltf")
    bad_index = np.frombuffer(binary, np.uint8).copy()
    bad_index[-8:-6] = np.frombuffer(np.uint16(60_000).tobytes(), np.uint8)
    yield case("glb-index-out-of-range", "mesh", glb(doc, bad_index.tobytes()), "index_out_of_range", "invalid_gltf")
    yield case("glb-joint-index-beyond-skin", "mesh", glb(doc, binary[:36] + bytes([0, 9, 0, 0] * 3) + binary[48:]),
               "invalid_gltf", OK)


def _raw_glb(json_chunk: bytes) -> bytes:
    body = json_chunk + b" " * (-len(json_chunk) % 4)
    return struct.pack("<4sII", b"glTF", 2, 20 + len(body)) + struct.pack("<I4s", len(body), b"JSON") + body


def motion_cases() -> Iterator[Case]:
    """glTF motion uploads: clips that are missing, mis-indexed or not there at all."""
    doc, binary = rigged_base()
    yield case("motion-gltf-valid", "motion", glb(doc, binary), OK)
    yield case("motion-gltf-no-animations", "motion", glb(_drop(doc, ("animations",)), binary), "no_clips")
    yield case("motion-gltf-no-skin", "motion", glb(_drop(_drop(doc, ("skins",)), ("nodes", 0, "skin")), binary),
               "no_skin")
    yield case("motion-gltf-sampler-oob", "motion", glb(_set(doc, ("animations", 0, "channels", 0, "sampler"), 3), binary),
               *BAD_GLTF)
    yield case("motion-gltf-nested", "motion", _nested(100_000), "json_too_deep")


def gltf_cases() -> Iterator[Case]:
    doc, binary = rigged_base()
    yield from _mutations(doc, binary)
    yield from _containers(doc, binary)
    yield from motion_cases()
