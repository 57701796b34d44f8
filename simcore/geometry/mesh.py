"""The ingested mesh every later stage works on."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from simcore.io.gltf_document import GltfDocument
    from simcore.io.gltf_rig import RiggedAsset


@dataclass
class IngestedMesh:
    """A cleaned static mesh in world space (+Y up, metres).

    vertices: (V, 3) float64, the POSITION arrays of `glb`'s primitives concatenated in order
              (meshes in index order, primitives in order), so vertex i of every later stage is
              vertex i of the exported file.
    faces:    (F, 3) int64 triangles into `vertices`.
    glb:      bytes of mesh.glb: one node per mesh, identity transforms, the input's UVs, normals,
              materials and textures kept.
    scale:    factor applied to the input's coordinates to get metres (units guess or option).
    source_rig: the input's own skin (skeleton + weights), expressed in this mesh's frame, when it had one.
    source_doc: the parsed input glTF (for animation clips carried by the upload), when it was glTF.
    stats:    JSON-ready statistics for report.json.
    """

    vertices: np.ndarray
    faces: np.ndarray
    glb: bytes
    scale: float = 1.0
    source_rig: RiggedAsset | None = None
    source_doc: GltfDocument | None = None
    stats: dict[str, Any] = field(default_factory=dict)
