"""Structural check of a glTF JSON tree before any reader touches it.

Every property a RigForge reader uses is checked for its JSON type, range and the index it names, so a
lying or malformed file fails with `invalid_gltf` and a message naming the property (`accessors[3].count
must be an integer ≥ 0`) instead of a KeyError deep in a reader. The node hierarchy is checked in linear
time (no shared children, no cycles, depth capped); nesting depth of the whole tree is capped too.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from simcore.errors import InvalidInput, LimitExceeded, UnsupportedFormat
from simcore.io.json_bounds import json_depth

MAX_JSON_DEPTH = 64  # real files nest ~8 deep; `extras` may add a little
MAX_NODE_DEPTH = 1024  # longest root-to-leaf node chain (a long rope or tail rig is ~200)
COMPONENT_TYPES = (5120, 5121, 5122, 5123, 5125, 5126)
ACCESSOR_TYPES = ("SCALAR", "VEC2", "VEC3", "VEC4", "MAT2", "MAT3", "MAT4")
# Extensions a file may *require*: decoded here (Draco), readable as plain accessors (quantization), or
# carried into the output unchanged (materials, textures, lights). Others cannot be honoured.
REQUIRABLE_EXTENSIONS = {"KHR_draco_mesh_compression", "KHR_mesh_quantization"}
REQUIRABLE_PREFIXES = ("KHR_materials_", "KHR_texture_", "EXT_texture_", "KHR_lights_")

Check = Callable[[Any, str, dict], None]  # (value, JSON path for messages, whole document)


def _fail(message: str) -> InvalidInput:
    return InvalidInput(message, code="invalid_gltf", field="mesh")


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _int(lo: int = 0, hi: int | None = None) -> Check:
    def check(value: Any, path: str, _: dict) -> None:
        if not _is_int(value) or value < lo or (hi is not None and value > hi):
            raise _fail(f"{path} must be an integer ≥ {lo}" + (f" and ≤ {hi}" if hi is not None else "") + f", found {value!r:.40}")
    return check


def _index(collection: str) -> Check:
    def check(value: Any, path: str, doc: dict) -> None:
        size = len(doc.get(collection, []))
        if not _is_int(value) or not 0 <= value < size:
            raise _fail(f"{path} = {value!r:.40} is not an index into {collection} (it has {size})")
    return check


def _enum(*allowed: Any) -> Check:
    def check(value: Any, path: str, _: dict) -> None:
        if isinstance(value, bool) or value not in allowed:
            raise _fail(f"{path} must be one of {', '.join(map(str, allowed))}, found {value!r:.40}")
    return check


def _numbers(length: int | None = None, nonzero: bool = False) -> Check:
    def check(value: Any, path: str, _: dict) -> None:
        ok = isinstance(value, list) and (length is None or len(value) == length) and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
        if not ok:
            raise _fail(f"{path} must be a list of {length or 'any number of'} finite numbers")
        if nonzero and not any(value):
            raise _fail(f"{path} must not be all zeros")
    return check


def _string(value: Any, path: str, _: dict) -> None:
    if not isinstance(value, str):
        raise _fail(f"{path} must be a string")


def _boolean(value: Any, path: str, _: dict) -> None:
    if not isinstance(value, bool):
        raise _fail(f"{path} must be true or false")


def _object(value: Any, path: str, _: dict) -> None:
    if not isinstance(value, dict):
        raise _fail(f"{path} must be an object")


def _list(item: Check, min_len: int = 0) -> Check:
    def check(value: Any, path: str, doc: dict) -> None:
        if not isinstance(value, list) or len(value) < min_len:
            raise _fail(f"{path} must be an array" + (f" of at least {min_len}" if min_len else ""))
        for i, v in enumerate(value):
            item(v, f"{path}[{i}]", doc)
    return check


def _map(item: Check) -> Check:
    def check(value: Any, path: str, doc: dict) -> None:
        _object(value, path, doc)
        for k, v in value.items():
            item(v, f"{path}.{k}", doc)
    return check


def _fields(spec: dict[str, Check], required: tuple[str, ...] = ()) -> Check:
    def check(value: Any, path: str, doc: dict) -> None:
        _object(value, path, doc)
        for name in required:
            if name not in value:
                raise _fail(f"{path} has no '{name}'")
        for name, sub in spec.items():
            if name in value:
                sub(value[name], f"{path}.{name}", doc)
    return check


_ACCESSOR = _index("accessors")
_VIEW = _index("bufferViews")
_SPARSE = _fields({
    "count": _int(1),
    "indices": _fields({"bufferView": _VIEW, "byteOffset": _int(0), "componentType": _enum(5121, 5123, 5125)},
                       ("bufferView", "componentType")),
    "values": _fields({"bufferView": _VIEW, "byteOffset": _int(0)}, ("bufferView",)),
}, ("count", "indices", "values"))
_PRIMITIVE = _fields({"attributes": _map(_ACCESSOR), "indices": _ACCESSOR, "material": _index("materials"),
                      "mode": _int(0, 6), "targets": _list(_map(_ACCESSOR)), "extensions": _object}, ("attributes",))
_CHANNEL = _fields({"sampler": _int(0), "target": _fields({"node": _index("nodes"), "path": _enum(
    "translation", "rotation", "scale", "weights")}, ("path",))}, ("sampler", "target"))
_ANIMATION_SAMPLER = _fields({"input": _ACCESSOR, "output": _ACCESSOR,
                              "interpolation": _enum("LINEAR", "STEP", "CUBICSPLINE")}, ("input", "output"))

SCHEMA: dict[str, Check] = {
    "buffers": _fields({"byteLength": _int(0), "uri": _string}, ("byteLength",)),
    "bufferViews": _fields({"buffer": _index("buffers"), "byteOffset": _int(0), "byteLength": _int(0),
                            "byteStride": _int(4, 252)}, ("buffer", "byteLength")),
    "accessors": _fields({"bufferView": _VIEW, "byteOffset": _int(0), "componentType": _enum(*COMPONENT_TYPES),
                          "normalized": _boolean, "count": _int(0), "type": _enum(*ACCESSOR_TYPES),
                          "min": _numbers(), "max": _numbers(), "sparse": _SPARSE}, ("componentType", "count", "type")),
    "meshes": _fields({"primitives": _list(_PRIMITIVE, 1), "weights": _numbers(), "extras": lambda *_: None},
                      ("primitives",)),
    "nodes": _fields({"children": _list(_index("nodes")), "skin": _index("skins"), "mesh": _index("meshes"),
                      "matrix": _numbers(16), "rotation": _numbers(4, nonzero=True), "scale": _numbers(3),
                      "translation": _numbers(3), "weights": _numbers()}),
    "skins": _fields({"inverseBindMatrices": _ACCESSOR, "skeleton": _index("nodes"),
                      "joints": _list(_index("nodes"), 1)}, ("joints",)),
    "scenes": _fields({"nodes": _list(_index("nodes"))}),
    "animations": _fields({"channels": _list(_CHANNEL, 1), "samplers": _list(_ANIMATION_SAMPLER, 1)},
                          ("channels", "samplers")),
    "images": _fields({"uri": _string, "mimeType": _string, "bufferView": _VIEW}),
    "textures": _fields({"sampler": _index("samplers"), "source": _index("images")}),
    "materials": _object, "samplers": _object, "cameras": _object,
}
TOP_LEVEL: dict[str, Check] = {"scene": _index("scenes"), "extensionsUsed": _list(_string),
                               "extensionsRequired": _list(_string), "extensions": _object}


def node_parents(nodes: list[dict]) -> np.ndarray:
    """(N,) int64 parent of each node (-1 for roots), checked in O(N): no shared child, no cycle, capped depth."""
    n = len(nodes)
    parents = np.full(n, -1, dtype=np.int64)
    for i, node in enumerate(nodes):
        for c in node.get("children", []):
            if not _is_int(c) or not 0 <= c < n or parents[c] >= 0 or c == i:
                raise _fail(f"nodes[{i}] has an invalid or shared child {c!r:.40}")
            parents[c] = i
    depth = np.full(n, -1, dtype=np.int64)  # -1 unknown; filled root-down along each walk
    parent_list = parents.tolist()
    for start in range(n):
        path, p = [], start
        while p >= 0 and depth[p] < 0:
            path.append(p)
            if len(path) > n:
                raise _fail("the node hierarchy has a cycle")
            p = parent_list[p]
        base = depth[p] if p >= 0 else -1
        for k, walked in enumerate(reversed(path)):
            depth[walked] = base + 1 + k
        if path and depth[path[0]] >= MAX_NODE_DEPTH:
            raise LimitExceeded(f"the node hierarchy is more than {MAX_NODE_DEPTH} levels deep",
                                code="hierarchy_too_deep", field="mesh")
    return parents


def validate_structure(doc: dict) -> None:
    """Raise InvalidInput/LimitExceeded/UnsupportedFormat for anything a reader could trip over."""
    if json_depth(doc, MAX_JSON_DEPTH) > MAX_JSON_DEPTH:
        raise LimitExceeded(f"the glTF JSON is nested more than {MAX_JSON_DEPTH} levels deep", code="json_too_deep", field="mesh")
    for key in SCHEMA:  # first, so every index check below can count a collection
        if key in doc and not isinstance(doc[key], list):
            raise _fail(f"'{key}' must be an array")
    for key, check in TOP_LEVEL.items():
        if key in doc:
            check(doc[key], key, doc)
    for key, item in SCHEMA.items():
        if key in doc:
            _list(item)(doc[key], key, doc)
    for a, anim in enumerate(doc.get("animations", [])):
        for c, channel in enumerate(anim["channels"]):
            if channel["sampler"] >= len(anim["samplers"]):
                raise _fail(f"animations[{a}].channels[{c}].sampler = {channel['sampler']} is not one of its samplers")
    node_parents(doc.get("nodes", []))
    unknown = sorted(e for e in doc.get("extensionsRequired", [])
                     if e not in REQUIRABLE_EXTENSIONS and not e.startswith(REQUIRABLE_PREFIXES))
    if unknown:
        raise UnsupportedFormat(f"the file requires the extension(s) {', '.join(unknown)}, which RigForge cannot honour; "
                                "export it without them", code="unsupported_format", field="mesh")
