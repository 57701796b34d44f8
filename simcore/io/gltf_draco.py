"""KHR_draco_mesh_compression: decode compressed primitives into plain accessors (DracoPy, Google's decoder).

Web pipelines ship Draco-compressed glTF. After `decompress_draco` the document reads like an uncompressed one:
each compressed primitive's attribute and index accessors point at decoded data in one extra in-memory buffer,
and the extension is gone from the primitives and from `extensionsRequired`/`extensionsUsed`. The vertex
order is the decoder's (the spec defines it so), and every later stage and export follows it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from simcore.errors import InvalidInput

if TYPE_CHECKING:
    from simcore.io.gltf_document import GltfDocument

EXTENSION = "KHR_draco_mesh_compression"
UINT32 = 5125


def _decode(blob: bytes, where: str):
    import DracoPy

    try:
        return DracoPy.decode(blob)
    except MemoryError:  # the worker's memory cap, not corrupt data
        raise
    except Exception as exc:  # noqa: BLE001 - the decoder raises several types for corrupt data
        raise InvalidInput(f"{where}: the Draco data could not be decoded ({type(exc).__name__})",
                           code="invalid_gltf", field="mesh") from exc


def decompress_draco(doc: GltfDocument) -> int:
    """Decode every Draco primitive of `doc` in place; returns how many were decoded."""
    from simcore.io.gltf_document import COMPONENT_DTYPES, TYPE_WIDTHS  # a cycle at import time, not at call time

    chunks: list[bytes] = []
    views = doc.json.setdefault("bufferViews", [])
    buffer_index = len(doc.buffers)
    size = 0
    decoded = 0

    def add_view(array: np.ndarray) -> int:
        nonlocal size
        data = np.ascontiguousarray(array).tobytes()
        pad = (-size) % 4
        chunks.append(b"\0" * pad + data)
        size += pad
        views.append({"buffer": buffer_index, "byteOffset": size, "byteLength": len(data)})
        size += len(data)
        return len(views) - 1

    for m, mesh in enumerate(doc.items("meshes")):
        for p, prim in enumerate(mesh.get("primitives", [])):
            ext = prim.get("extensions", {}).get(EXTENSION)
            if ext is None:
                continue
            where = f"meshes[{m}].primitives[{p}]"
            blob, _ = doc.view_bytes(int(ext["bufferView"]))
            draco = _decode(blob, where)
            for name, uid in ext.get("attributes", {}).items():
                if name not in prim.get("attributes", {}):
                    continue
                attribute = draco.get_attribute_by_unique_id(int(uid))
                if attribute is None:
                    raise InvalidInput(f"{where}: Draco data has no attribute {uid} for {name}", code="invalid_gltf", field="mesh")
                acc = doc.items("accessors")[int(prim["attributes"][name])]
                values = np.asarray(attribute["data"]).reshape(-1, TYPE_WIDTHS[acc["type"]])
                acc.update(bufferView=add_view(values.astype(COMPONENT_DTYPES[acc["componentType"]])), byteOffset=0, count=len(values))
            if "indices" in prim:
                if not hasattr(draco, "faces"):
                    raise InvalidInput(f"{where}: the Draco data is a point cloud but the primitive has indices",
                                       code="invalid_gltf", field="mesh")
                faces = np.asarray(draco.faces, dtype=np.uint32).reshape(-1)
                acc = doc.items("accessors")[int(prim["indices"])]
                acc.update(bufferView=add_view(faces), byteOffset=0, count=len(faces), componentType=UINT32)
            del prim["extensions"][EXTENSION]
            decoded += 1
    if decoded:
        doc.buffers.append(b"".join(chunks))
        doc.json.setdefault("buffers", []).append({"byteLength": size})
        for key in ("extensionsRequired", "extensionsUsed"):
            if EXTENSION in doc.json.get(key, []):
                doc.json[key] = [e for e in doc.json[key] if e != EXTENSION]
    return decoded
