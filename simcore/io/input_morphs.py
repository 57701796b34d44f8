"""An upload's own morph targets (blend shapes: visemes, expressions, correctives), carried into mesh.glb.

Ingest bakes every vertex into the converted rest frame with a per-vertex linear map M (node transform or
blended skin, then units and up axis). A target's position deltas are displacements, so they take M alone;
normal deltas take M⁻ᵀ and tangent deltas M, each scaled by the factor that renormalised the vertex's own
normal or tangent, so base + delta keeps pointing where it pointed. Default weights and target names go along.
"""

from __future__ import annotations

import numpy as np

from simcore.io.glb_packer import ARRAY_BUFFER, GlbBuilder
from simcore.io.gltf_document import GltfDocument


def _scaled(maps: np.ndarray, delta: np.ndarray, base: np.ndarray | None) -> np.ndarray:
    """(V, 3) maps @ delta, divided per vertex by |maps @ base| (the base vector's renormalisation)."""
    out = np.einsum("vab,vb->va", maps, delta)
    if base is not None:
        out /= np.maximum(np.linalg.norm(np.einsum("vab,vb->va", maps, base[:, :3]), axis=1, keepdims=True), 1e-12)
    return out


def baked_targets(doc: GltfDocument, prim: dict, linear: np.ndarray, builder: GlbBuilder) -> list[dict]:
    """The primitive's targets as accessors of `builder`, deltas in the baked frame.

    linear: (V, 3, 3) per-vertex linear part of the bake. Returns the glTF `targets` list (empty when none).
    """
    attrs = prim.get("attributes", {})
    normals = doc.accessor(attrs["NORMAL"]).astype(np.float64) if "NORMAL" in attrs else None
    tangents = doc.accessor(attrs["TANGENT"]).astype(np.float64) if "TANGENT" in attrs else None
    inverse_t = np.linalg.inv(linear).transpose(0, 2, 1)
    out = []
    for target in prim.get("targets", []):
        baked: dict[str, int] = {}
        for name, maps, base in (("POSITION", linear, None), ("NORMAL", inverse_t, normals), ("TANGENT", linear, tangents)):
            if name not in target or (name != "POSITION" and base is None):
                continue
            delta = doc.accessor(target[name]).astype(np.float64)[:, :3]
            baked[name] = builder.add_accessor(_scaled(maps, delta, base).astype(np.float32), target=ARRAY_BUFFER,
                                               minmax=name == "POSITION")
        out.append(baked)
    return out


def target_defaults(src_mesh: dict, node: dict, count: int) -> dict:
    """Mesh-level `weights` (the node's override wins) and `extras.targetNames` for `count` targets; unnamed
    targets are called shape_0, shape_1… so every later writer finds one name per target here."""
    if not count:
        return {}
    weights = node.get("weights", src_mesh.get("weights", [0.0] * count))
    names = src_mesh.get("extras", {}).get("targetNames") if isinstance(src_mesh.get("extras"), dict) else None
    if not (isinstance(names, list) and len(names) == count):
        names = [f"shape_{i}" for i in range(count)]
    return {"weights": [float(w) for w in weights][:count] + [0.0] * max(count - len(weights), 0),
            "extras": {"targetNames": [str(n) for n in names]}}
