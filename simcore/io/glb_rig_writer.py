"""Rigged GLB export: our ingested mesh.glb plus a joint hierarchy, a skin and JOINTS/WEIGHTS.

The original mesh data (vertex order, indices, normals, UVs, materials, textures) is kept byte for byte
(see glb_packer). What is added: one joint node per skeleton joint with local TRS, a skin whose
inverseBindMatrices invert `bind_matrices(skeleton)`, JOINTS_n/WEIGHTS_n on every primitive, and
optionally a glTF animation (glb_animation) and refinement morph targets (morph_bake).
Node layout written: mesh nodes first (one per mesh, untransformed scene roots, as glTF wants for
skinned meshes), then the joints in skeleton order (a kept rig's: its upload's order and roots, see file_layout);
the scene lists the mesh nodes and the root joints.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
from scipy.spatial.transform import Rotation

from simcore.errors import InvalidInput
from simcore.io.file_layout import file_animation, file_skeleton, file_weights
from simcore.io.glb_packer import ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER, GlbBuilder
from simcore.io.mesh_layout import MeshLayout, read_mesh_layout
from simcore.io.skin_influences import Influences, top_influences
from simcore.skeleton.kinematics import bind_matrices, rest_local_matrices
from simcore.skeleton.types import Skeleton

if TYPE_CHECKING:
    from simcore.motion.types import JointAnimation


def _joint_nodes(skeleton: Skeleton) -> list[dict]:
    """glTF nodes (TRS, children as skeleton indices) for every joint at rest."""
    local = rest_local_matrices(skeleton)
    quats = Rotation.from_matrix(local[:, :3, :3]).as_quat()
    children = skeleton.children()
    out = []
    for j in range(skeleton.num_joints):
        node: dict = {"name": skeleton.names[j], "translation": [float(x) for x in local[j, :3, 3]]}
        if not np.allclose(quats[j], [0, 0, 0, 1], atol=1e-12):
            q = quats[j] / np.linalg.norm(quats[j])
            node["rotation"] = [float(x) for x in q.astype(np.float32)]
        if children[j]:
            node["children"] = list(children[j])
        out.append(node)
    return out


def _add_skin_attributes(builder: GlbBuilder, layout: MeshLayout, infl: Influences, joint_count: int) -> None:
    joint_dtype = np.uint8 if joint_count <= 256 else np.uint16
    meshes = builder.json["meshes"]
    for s in layout.slices:
        attrs = meshes[s.mesh]["primitives"][s.primitive]["attributes"]
        for key in [k for k in attrs if k.startswith(("JOINTS_", "WEIGHTS_"))]:
            del attrs[key]
        rows = slice(s.start, s.start + s.count)
        for set_index in range(infl.joints.shape[1] // 4):
            cols = slice(4 * set_index, 4 * set_index + 4)
            attrs[f"JOINTS_{set_index}"] = builder.add_accessor(
                infl.joints[rows, cols].astype(joint_dtype), target=ARRAY_BUFFER)
            attrs[f"WEIGHTS_{set_index}"] = builder.add_accessor(
                np.ascontiguousarray(infl.weights[rows, cols]), target=ARRAY_BUFFER)


def mark_vertex_views(gltf: dict) -> None:
    """Set bufferView.target on views that hold only vertex attributes or only indices (validator hint)."""
    roles: dict[int, set[str]] = {}
    accessors = gltf.get("accessors", [])
    used: dict[int, str] = {}
    for mesh in gltf.get("meshes", []):
        for prim in mesh.get("primitives", []):
            for acc in [*prim.get("attributes", {}).values(), *(a for t in prim.get("targets", []) for a in t.values())]:
                used[acc] = "vertex"
            if "indices" in prim:
                used[prim["indices"]] = "index"
    for i, acc in enumerate(accessors):
        if "bufferView" in acc:
            roles.setdefault(acc["bufferView"], set()).add(used.get(i, "other"))
        if "sparse" in acc:
            for part in ("indices", "values"):
                roles.setdefault(acc["sparse"][part]["bufferView"], set()).add("other")
    for image in gltf.get("images", []):
        if "bufferView" in image:
            roles.setdefault(image["bufferView"], set()).add("other")
    views = gltf.get("bufferViews", [])
    for view_index, role in roles.items():
        if role in ({"vertex"}, {"index"}) and "target" not in views[view_index]:
            views[view_index]["target"] = ARRAY_BUFFER if role == {"vertex"} else ELEMENT_ARRAY_BUFFER


@dataclass
class GlbExport:
    """The written file and what report.json should know about it."""

    data: bytes
    influences: Influences
    stats: dict


def write_rigged_glb(
    mesh_glb: bytes,
    skeleton: Skeleton,
    weights: sp.spmatrix,
    *,
    max_influences: int = 4,
    animation: JointAnimation | None = None,
    morph_frames: np.ndarray | None = None,
    max_morph_targets: int = 256,
    morph_rate: float | None = None,
    morph_tolerance: float | None = None,
    out_path: Path | None = None,
) -> GlbExport:
    """Rig mesh.glb with `skeleton` and `weights`; optionally animate it and bake refined frames.

    mesh_glb:     bytes of the ingest's mesh.glb (one node per mesh, identity transforms).
    skeleton:     validated Skeleton in the mesh's space (bind pose = rest pose).
    weights:      (V, J) sparse float, V = total POSITION count of mesh.glb in mesh/primitive order.
    max_influences: 4 or 8 (8 writes JOINTS_1/WEIGHTS_1).
    animation:    clip for this skeleton (frame k at k / fps, LINEAR sampler).
    morph_frames: (T, V, 3) float world vertex positions at animation frames 0..T-1 (physics refinement),
                  baked as morph targets on top of the skinned animation (see morph_bake).
    max_morph_targets: cap on targets; longer clips key a uniform subset of frames, LINEAR between them.
    morph_rate:   most morph keys per second (the simulation's rate: the frames between were interpolated);
                  None keys every frame.
    morph_tolerance: vertex error the compact morph form may add, as a fraction of the bind pose's largest
                  bounding-box side (default morph_compact.TOLERANCE; see glb_animation).
    out_path:     when given, the file is written there too.
    """
    if max_influences not in (4, 8):
        raise InvalidInput("max_influences must be 4 or 8", code="invalid_option", field="max_influences")
    skeleton.validate()
    layout = read_mesh_layout(mesh_glb)
    w = sp.csr_matrix(weights)
    if w.shape != (len(layout.vertices), skeleton.num_joints):
        raise InvalidInput(
            f"weights are {w.shape[0]}x{w.shape[1]} but mesh.glb has {len(layout.vertices)} vertices "
            f"and the skeleton {skeleton.num_joints} joints", code="export_shape_mismatch", field="weights")
    if morph_frames is not None and animation is None:
        raise InvalidInput("refined frames need the animation they refine", code="export_shape_mismatch",
                           field="refined_frames")
    written, order = file_skeleton(skeleton)  # a kept rig goes back in its upload's joint order and roots
    if animation is not None:
        animation = file_animation(skeleton, written, animation)
    skeleton, w = written, file_weights(w, order)
    infl = top_influences(w, max_influences, layout.vertices, skeleton.positions)

    source = layout.doc
    base = {k: v for k, v in source.json.items() if k not in ("nodes", "scenes", "scene", "skins", "animations")}
    base.setdefault("asset", {"version": "2.0"})["generator"] = "RigForge"
    builder = GlbBuilder(base, source.buffers[0] if source.buffers else b"")
    _add_skin_attributes(builder, layout, infl, skeleton.num_joints)

    mesh_count = len(builder.json["meshes"])
    joint_base = mesh_count
    nodes = [{"name": layout.mesh_node_names[m], "mesh": m, "skin": 0} for m in range(mesh_count)]
    for node in _joint_nodes(skeleton):
        if "children" in node:
            node["children"] = [joint_base + c for c in node["children"]]
        nodes.append(node)
    builder.json["nodes"] = nodes
    ibm = np.linalg.inv(bind_matrices(skeleton)).transpose(0, 2, 1).reshape(-1, 16)  # column-major per joint
    roots = [joint_base + int(r) for r in np.flatnonzero(skeleton.parents < 0)]
    skin = {
        "name": "skeleton",
        "inverseBindMatrices": builder.add_accessor(ibm.astype(np.float32)),
        "joints": list(range(joint_base, joint_base + skeleton.num_joints)),
    }
    if len(roots) == 1:  # glTF's skeleton root is a common root of every joint
        skin["skeleton"] = roots[0]
    builder.json["skins"] = [skin]
    builder.json["scenes"] = [{"name": "rigged", "nodes": list(range(mesh_count)) + roots}]
    builder.json["scene"] = 0

    stats: dict = {"influences": infl.stats}
    if animation is not None:
        from simcore.io.glb_animation import add_joint_animation, add_morph_animation

        clip = add_joint_animation(builder, skeleton, animation, joint_base)
        stats["animation"] = {"name": animation.name, "frames": animation.num_frames, "fps": animation.fps,
                              "channels": len(clip["channels"])}
        if morph_frames is not None:
            from simcore.io.glb_animation import morph_key_frames
            from simcore.io.morph_bake import bind_space_offsets
            from simcore.io.morph_compact import TOLERANCE

            count = len(morph_frames)
            keys = morph_key_frames(count, max_morph_targets, animation.fps, morph_rate)
            offsets = bind_space_offsets(layout.vertices, skeleton, infl, animation, np.asarray(morph_frames)[keys],
                                         frames=keys)
            size = float(np.ptp(layout.vertices, axis=0).max()) if len(layout.vertices) else 0.0
            fraction = TOLERANCE if morph_tolerance is None else morph_tolerance
            stats["morph"] = add_morph_animation(builder, clip, layout.slices, offsets, keys, count, animation.fps,
                                                 max_morph_targets, tolerance=fraction * size)
        builder.json["animations"] = [clip]
    mark_vertex_views(builder.json)
    data = builder.to_glb()
    if out_path is not None:
        Path(out_path).write_bytes(data)
    stats["bytes"] = len(data)
    return GlbExport(data, infl, stats)
