"""The vertex layout of our ingested mesh.glb: primitives in mesh/primitive order, POSITION concatenated.

This is the contract between ingest and every exporter: vertex i of IngestedMesh.vertices (and row i of
the weights) is vertex i of this concatenation.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from simcore.errors import InvalidInput
from simcore.io.gltf_document import GltfDocument


@dataclass
class PrimitiveSlice:
    """Where one glTF primitive's vertices sit in the concatenated vertex array."""

    mesh: int
    primitive: int
    start: int
    count: int


@dataclass
class MeshLayout:
    """The static mesh document and its vertex layout.

    slices:    primitives in mesh/primitive order with their vertex ranges.
    vertices:  (V, 3) float64 concatenated POSITION data (bind pose, world space).
    mesh_node_names: a name for each mesh's node.
    """

    doc: GltfDocument
    slices: list[PrimitiveSlice]
    vertices: np.ndarray
    mesh_node_names: list[str] = field(default_factory=list)


def _export_error(message: str) -> InvalidInput:
    return InvalidInput(message, code="export_mesh_layout", field="mesh")


def read_mesh_layout(mesh_glb: bytes) -> MeshLayout:
    """Parse mesh.glb and check the ingest contract: every mesh on at most one untransformed node."""
    doc = GltfDocument.from_bytes(mesh_glb)
    meshes = doc.items("meshes")
    nodes = doc.items("nodes")
    if not meshes:
        raise _export_error("mesh.glb has no meshes")
    world = doc.world_matrices() if nodes else np.zeros((0, 4, 4))
    names = [str(m.get("name") or f"mesh{i}") for i, m in enumerate(meshes)]
    users: dict[int, int] = {}
    for n, node in enumerate(nodes):
        if "mesh" not in node:
            continue
        m = int(node["mesh"])
        if m in users:
            raise _export_error(f"mesh {m} is instanced by several nodes; ingest must give each its own mesh")
        if not np.allclose(world[n], np.eye(4), atol=1e-6):
            raise _export_error(f"node {n} transforms mesh {m}; ingest must bake transforms into the vertices")
        users[m] = n
        names[m] = str(node.get("name") or names[m])
    slices, verts, start = [], [], 0
    for m, mesh in enumerate(meshes):
        for p, prim in enumerate(mesh.get("primitives", [])):
            if "POSITION" not in prim.get("attributes", {}):
                raise _export_error(f"meshes[{m}].primitives[{p}] has no POSITION")
            v = doc.accessor(prim["attributes"]["POSITION"]).astype(np.float64)
            slices.append(PrimitiveSlice(m, p, start, len(v)))
            verts.append(v)
            start += len(v)
    return MeshLayout(doc, slices, np.concatenate(verts) if verts else np.zeros((0, 3)), names)
