"""Bake an uploaded glTF into our static mesh.glb: every mesh instance in world space in one pose of its
nodes (ingest passes the skin's bind pose, simcore.io.bind_pose; by default the nodes' rest pose), converted to
metres / +Y up, with its UVs, normals, vertex colours, materials and textures.

Skinned primitives are posed by their skin (Σ w · world(joint) · inverseBind), not by the mesh node's
transform, which glTF says to ignore for skinned meshes.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from simcore.errors import InvalidInput
from simcore.io.glb_packer import ARRAY_BUFFER, GlbBuilder
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import MODES_TRIANGLES, TRIANGLE_MODES, check_finite_weights, primitive_triangles
from simcore.io.input_morphs import baked_targets, target_defaults

ELEMENT_ARRAY_BUFFER = 34963
KEPT_ATTRIBUTES = ("POSITION", "NORMAL", "TANGENT", "TEXCOORD_0", "TEXCOORD_1", "COLOR_0")


def skin_rest_matrices(doc: GltfDocument, skin_index: int, world: np.ndarray) -> np.ndarray:
    """(J, 4, 4) world(joint) @ inverseBind of a skin, `world` (N, 4, 4) holding every node's world transform."""
    skin = doc.items("skins")[skin_index]
    joints = np.asarray(skin.get("joints", []), dtype=np.int64)
    if "inverseBindMatrices" in skin:
        ibm = doc.accessor(skin["inverseBindMatrices"]).astype(np.float64).reshape(-1, 4, 4).transpose(0, 2, 1)
    else:
        ibm = np.tile(np.eye(4), (len(joints), 1, 1))
    return world[joints] @ ibm


def _vertex_matrices(doc: GltfDocument, node: dict, prim: dict, node_world: np.ndarray, count: int, world: np.ndarray) -> np.ndarray:
    """(count, 4, 4) per-vertex transform in the pose `world` holds (the node's world, or the blended skin matrices)."""
    attrs = prim["attributes"]
    if "skin" not in node or "JOINTS_0" not in attrs or "WEIGHTS_0" not in attrs:
        return np.broadcast_to(node_world, (count, 4, 4))
    mats = skin_rest_matrices(doc, int(node["skin"]), world)
    blended = np.zeros((count, 4, 4))
    s = 0
    while f"JOINTS_{s}" in attrs and f"WEIGHTS_{s}" in attrs:
        ji = doc.accessor(attrs[f"JOINTS_{s}"]).astype(np.int64)
        wi = doc.accessor(attrs[f"WEIGHTS_{s}"]).astype(np.float64)
        check_finite_weights(wi, s)
        if ji.size and ji.max() >= len(mats):
            raise InvalidInput("JOINTS_n index beyond the skin's joints", code="invalid_gltf", field="mesh")
        blended += np.einsum("vk,vkab->vab", wi, mats[ji])
        s += 1
    total = blended[:, 3, 3:4, None]  # the weights' sum; unweighted vertices follow the node
    unweighted = total[:, 0, 0] < 1e-8
    blended[unweighted] = node_world
    blended[~unweighted] /= total[~unweighted]
    return blended


def _copy_images(doc: GltfDocument, builder: GlbBuilder) -> None:
    """Carry images stored in buffer views over into the new buffer (data: URIs are kept as they are)."""
    for image in builder.json.get("images", []):
        if "bufferView" in image:
            view = doc.items("bufferViews")[image["bufferView"]]
            blob = doc.buffers[view.get("buffer", 0)][view.get("byteOffset", 0): view.get("byteOffset", 0) + view["byteLength"]]
            image["bufferView"] = builder.add_view(blob)


def bake_static_glb(doc: GltfDocument, conversion: np.ndarray, world: np.ndarray | None = None) -> tuple[bytes, np.ndarray, np.ndarray]:
    """Returns (mesh.glb bytes, vertices (V, 3) float64, faces (F, 3) int64) in the converted frame.

    conversion: (4, 4) similarity transform applied after the pose (units and up axis).
    world: (N, 4, 4) every node's world transform in the pose to bake (simcore.io.bind_pose); None: the rest pose.
    """
    base = {k: doc.json[k] for k in ("materials", "textures", "images", "samplers") if k in doc.json}
    base["asset"] = {"version": "2.0", "generator": "RigForge ingest"}
    builder = GlbBuilder(base)
    builder.json["bufferViews"] = []
    _copy_images(doc, builder)
    world = doc.world_matrices() if world is None else world
    scene_nodes, all_verts, all_faces, offset = [], [], [], 0
    n_materials = len(doc.json.get("materials", []))
    for n, node in enumerate(doc.items("nodes")):
        if "mesh" not in node:
            continue
        src_mesh = doc.items("meshes")[int(node["mesh"])]
        primitives: list[dict[str, Any]] = []
        for prim in src_mesh.get("primitives", []):
            attrs = prim.get("attributes", {})
            if "POSITION" not in attrs or prim.get("mode", MODES_TRIANGLES) not in TRIANGLE_MODES:  # strips and fans become lists
                continue
            pos = doc.accessor(attrs["POSITION"]).astype(np.float64)
            faces = primitive_triangles(doc, prim, len(pos))
            m = conversion @ _vertex_matrices(doc, node, prim, world[n], len(pos), world)
            new_pos = np.einsum("vab,vb->va", m[:, :3, :3], pos) + m[:, :3, 3]
            mirrored = np.linalg.det(m[faces[:, 0], :3, :3]) < 0  # a mirroring transform turns triangles inside out
            faces[mirrored] = faces[mirrored][:, ::-1]
            out_attrs = {"POSITION": builder.add_accessor(new_pos.astype(np.float32), target=ARRAY_BUFFER, minmax=True)}
            for name in KEPT_ATTRIBUTES[1:]:
                if name not in attrs:
                    continue
                data = doc.accessor(attrs[name]).astype(np.float32)
                if name in ("NORMAL", "TANGENT"):
                    rotated = np.einsum("vab,vb->va", np.linalg.inv(m[:, :3, :3]).transpose(0, 2, 1), data[:, :3])
                    rotated /= np.maximum(np.linalg.norm(rotated, axis=1, keepdims=True), 1e-12)
                    handedness = data[:, 3:] * np.sign(np.linalg.det(m[:, :3, :3]))[:, None]  # a mirror flips the bitangent
                    data = np.concatenate([rotated, handedness], axis=1).astype(np.float32)
                out_attrs[name] = builder.add_accessor(data, target=ARRAY_BUFFER)
            out = {"attributes": out_attrs, "mode": 4,
                   "indices": builder.add_accessor(faces.reshape(-1).astype(np.uint32), target=ELEMENT_ARRAY_BUFFER)}
            if isinstance(prim.get("material"), int) and prim["material"] < n_materials:
                out["material"] = prim["material"]
            targets = baked_targets(doc, prim, m[:, :3, :3], builder)
            if targets:
                out["targets"] = targets
            primitives.append(out)
            all_verts.append(new_pos)
            all_faces.append(faces + offset)
            offset += len(pos)
        if primitives:
            morphs = target_defaults(src_mesh, node, len(primitives[0].get("targets", [])))
            mesh_index = builder.add("meshes", {"name": str(src_mesh.get("name") or f"mesh{n}"), "primitives": primitives, **morphs})
            scene_nodes.append(builder.add("nodes", {"name": str(node.get("name") or f"node{n}"), "mesh": mesh_index}))
    if not all_verts:
        raise InvalidInput("the file contains no triangle meshes", code="empty_mesh", field="mesh")
    builder.json["scenes"] = [{"nodes": scene_nodes}]
    builder.json["scene"] = 0
    _declare_extensions(builder.json, doc.json)
    return builder.to_glb(), np.concatenate(all_verts), np.concatenate(all_faces)


def _extension_names(tree) -> set[str]:
    """Names of every `extensions` entry anywhere inside a JSON tree."""
    if isinstance(tree, dict):
        found = set(tree.get("extensions", {})) if isinstance(tree.get("extensions"), dict) else set()
        return found.union(*(_extension_names(v) for v in tree.values()))
    if isinstance(tree, list):
        return set().union(*(_extension_names(v) for v in tree))
    return set()


def _declare_extensions(out: dict, source: dict) -> None:
    """Declare the extensions the kept materials, textures and images use (the validator rejects undeclared
    ones, e.g. Blender's KHR_materials_emissive_strength); required stays required where it was."""
    used = sorted(_extension_names({k: v for k, v in out.items() if k not in ("extensionsUsed", "extensionsRequired")}))
    if used:
        out["extensionsUsed"] = used
        required = [e for e in source.get("extensionsRequired", []) if e in used]
        if required:
            out["extensionsRequired"] = required


def static_arrays(doc: GltfDocument) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (V, 3) float64, faces (F, 3) int64) of a static mesh.glb, meshes and primitives in order."""
    verts, faces, offset = [], [], 0
    for mesh in doc.items("meshes"):
        for prim in mesh.get("primitives", []):
            pos = doc.accessor(prim["attributes"]["POSITION"]).astype(np.float64)
            faces.append(primitive_triangles(doc, prim, len(pos)) + offset)
            verts.append(pos)
            offset += len(pos)
    if not verts:
        raise InvalidInput("the file contains no triangle meshes", code="empty_mesh", field="mesh")
    return np.concatenate(verts), np.concatenate(faces)
