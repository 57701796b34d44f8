"""A mirrored node (negative scale, common for the second half of a symmetric model) must not turn its mesh inside out."""

from __future__ import annotations

import pytest
import trimesh
from tests.simcore.io.rig_export_fixtures import capsule_glb, glb_with_json

from simcore.ingest import ingest


@pytest.mark.parametrize("scale", [[-1.0, 1.0, 1.0], [-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]])
def test_baked_triangles_keep_facing_outwards(scale: list[float]) -> None:
    def place(doc: dict) -> None:
        for node in doc["nodes"]:
            if "mesh" in node:
                node["scale"] = scale

    mesh = ingest(glb_with_json(capsule_glb()[0], place), "glb")
    solid = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    assert solid.volume > 0  # outward winding: negative for an inside-out mesh
