"""Stage 1, ingest: load and validate the upload, normalise to metres and +Y up, write mesh.glb + stats."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from simcore.errors import InvalidInput, LimitExceeded
from simcore.geometry.mesh import IngestedMesh
from simcore.geometry.mesh_stats import mesh_stats
from simcore.geometry.parts import bulk_size, surface_parts
from simcore.geometry.referenced import referenced_mesh
from simcore.geometry.similarity import rotation_from_covariance
from simcore.io.bind_pose import bind_pose_worlds
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import RiggedAsset, read_rigged_asset, rig_rest_matrices
from simcore.io.gltf_static import bake_static_glb, static_arrays
from simcore.io.gltf_zip import glb_from_zip
from simcore.io.obj_polygons import check_polygon_sizes
from simcore.pipeline import PipelineState, StageProgress
from simcore.skeleton.types import Skeleton

UP_TO_Y = {  # rotation taking the named up axis to +Y (right-handed, determinant +1)
    "y": np.eye(3), "-y": np.diag([1.0, -1.0, -1.0]),
    "z": np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]]), "-z": np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]),
    "x": np.array([[0.0, 1, 0], [-1, 0, 0], [0, 0, 1]]).T, "-x": np.array([[0.0, 1, 0], [-1, 0, 0], [0, 0, 1]]),
}
UNIT_SCALE = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254}
DEFAULT_MAX_VERTICES = 2_000_000


def guess_units(extent: float) -> str:
    """A character is 0.05–20 m; bigger numbers are centimetres, then millimetres."""
    if extent > 2000:
        return "mm"
    return "cm" if extent > 20 else "m"


def guess_up_axis(fmt: str, extents: np.ndarray) -> str:
    """glTF and OBJ are +Y up by convention; STL/PLY come from CAD and scanners, usually +Z up."""
    if fmt in ("glb", "gltf", "obj"):
        return "y"
    return "z" if extents[2] >= extents[1] else "y"


def conversion_matrix(up_axis: str, scale: float) -> np.ndarray:
    """(4, 4) rotation of `up_axis` onto +Y followed by a uniform scale to metres."""
    m = np.eye(4)
    m[:3, :3] = UP_TO_Y[up_axis] * scale
    return m


def _load_other(data: bytes, fmt: str) -> tuple[np.ndarray, np.ndarray, list]:
    """OBJ/PLY/STL through trimesh: world-space geometries in scene-graph order (vertex order kept)."""
    import trimesh

    if fmt == "obj":
        check_polygon_sizes(data)
    try:
        scene = trimesh.load(io.BytesIO(data), file_type=fmt, force="scene", process=False)
    except MemoryError:  # the worker's memory cap, not a broken file
        raise
    except Exception as exc:  # noqa: BLE001 - trimesh raises many types for broken files
        message = f"the {fmt.upper()} file could not be read: {type(exc).__name__}: {exc}"[:500]
        raise InvalidInput(message, code="unreadable_mesh", field="mesh") from exc
    assert isinstance(scene, trimesh.Scene)  # force="scene"; trimesh types load() as returning any Geometry
    geoms = []
    for node in scene.graph.nodes_geometry:
        transform, name = scene.graph[node]
        geom = scene.geometry[name]
        if isinstance(geom, trimesh.Trimesh) and len(geom.faces):
            geoms.append(geom.copy().apply_transform(transform))
    if not geoms:
        raise InvalidInput("the file contains no triangle meshes", code="empty_mesh", field="mesh")
    return np.concatenate([g.vertices for g in geoms]), np.concatenate([g.faces for g in geoms]), geoms


def _check(vertices: np.ndarray, faces: np.ndarray, max_vertices: int) -> None:
    if vertices.ndim != 2 or vertices.shape[1] != 3 or faces.ndim != 2 or faces.shape[1] != 3:
        raise InvalidInput("vertices need three coordinates and faces three corners", code="unreadable_mesh", field="mesh")
    if len(vertices) == 0 or len(faces) == 0:
        raise InvalidInput("the mesh has no triangles", code="empty_mesh", field="mesh")
    if len(vertices) > max_vertices:
        raise LimitExceeded(f"the mesh has {len(vertices)} vertices; the limit is {max_vertices}", code="too_many_vertices", field="mesh")
    if not np.all(np.isfinite(vertices)):
        raise InvalidInput("the mesh has NaN or infinite vertex coordinates", code="non_finite", field="mesh")
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise InvalidInput("a face refers to a vertex that does not exist", code="index_out_of_range", field="mesh")


def _bind_pose(doc: GltfDocument) -> tuple[RiggedAsset | None, np.ndarray]:
    """(the upload's rig, or None without a skinned mesh; every node's world transform with that rig at its
    bind pose, or at the nodes' rest pose without one). The bind pose is what we rig (simcore.io.bind_pose)."""
    if not any("skin" in n for n in doc.items("nodes")):
        return None, doc.world_matrices()
    rig = read_rigged_asset(doc)
    return rig, bind_pose_worlds(doc, rig)


def _source_rig(doc: GltfDocument, rig: RiggedAsset, world: np.ndarray, conversion: np.ndarray, vertices: np.ndarray) -> RiggedAsset:
    """The upload's own skin `rig` in our frame at the pose `world` (N, 4, 4) holds, weights re-indexed to our
    vertex order."""
    from scipy.spatial import cKDTree

    joints_world = conversion @ world[rig.joint_nodes]
    skin = rig_rest_matrices(doc, rig, world)  # in our joint order, every skin of the file
    rig_vertices = np.einsum("vj,jab->vab", rig.weights.toarray(), conversion @ skin)
    rig_vertices = np.einsum("vab,vb->va", rig_vertices[:, :3, :3], rig.vertices) + rig_vertices[:, :3, 3]
    dist, index = cKDTree(rig_vertices).query(vertices)
    weights = rig.weights[index]  # each of our vertices takes the skin of the nearest skinned vertex
    rows = np.flatnonzero(dist > 1e-4 * max(np.ptp(vertices, axis=0).max(), 1e-9))
    weights = weights.tolil()
    for r in rows:
        weights.rows[r], weights.data[r] = [], []
    rig.weights = weights.tocsr()
    rotations = rotation_from_covariance(joints_world[:, :3, :3])  # nearest proper rotations: a mirrored joint too
    rig.skeleton = Skeleton(joints_world[:, :3, 3], rig.skeleton.parents, rig.skeleton.names, [],
                            Rotation.from_matrix(rotations).as_quat(), rig.skeleton.file_order, rig.skeleton.file_parents)
    rig.vertices = vertices
    rig.bind_matrices = joints_world
    return rig


def ingest(data: bytes, fmt: str, *, up_axis: str | None = None, units: str = "auto",
           max_vertices: int = DEFAULT_MAX_VERTICES) -> IngestedMesh:
    """Load an upload of format `fmt` (glb, gltf, zip, obj, ply, stl) into an IngestedMesh (+Y up, metres)."""
    warnings: list[str] = []
    if fmt == "zip":  # a .gltf with its .bin and images, packed into one GLB so its textures are kept
        data, fmt = glb_from_zip(data), "glb"
    doc = GltfDocument.from_bytes(data) if fmt in ("glb", "gltf") else None
    rig, world = _bind_pose(doc) if doc is not None else (None, None)
    if doc is not None:
        raw_vertices, raw_faces = bake_static_glb(doc, np.eye(4), world)[1:]
    else:
        raw_vertices, raw_faces, geoms = _load_other(data, fmt)
    _check(raw_vertices, raw_faces, max_vertices)
    extents = np.ptp(referenced_mesh(raw_vertices, raw_faces).vertices, axis=0)  # stray vertices set no size
    up_guess = guess_up_axis(fmt, extents)
    size = float(extents.max())
    if guess_units(size) != "m":  # big, or a small part far away makes it look big: size it by its bulk
        size = bulk_size(surface_parts(raw_vertices, raw_faces))
    unit_guess = guess_units(size)
    up = up_axis or up_guess
    unit = unit_guess if units == "auto" else units
    if units == "auto" and unit != "m":
        warnings.append(f"coordinates look like {unit} (size {size:.1f}); scaled to metres")
    if up_axis is None and up != "y":
        warnings.append(f"no up axis given; guessed +{up.upper()} up for a {fmt.upper()} file and rotated it to +Y")
    conversion = conversion_matrix(up, UNIT_SCALE[unit])
    if doc is not None:
        glb, vertices, faces = bake_static_glb(doc, conversion, world)
    else:
        import trimesh

        scene = trimesh.Scene([g.apply_transform(conversion) for g in geoms])
        glb = scene.export(file_type="glb")
        vertices, faces = static_arrays(GltfDocument.from_bytes(glb))
    _check(vertices, faces, max_vertices)
    stats = mesh_stats(vertices, faces)
    stats.update(format=fmt, units_guess=unit_guess, units_applied=unit, scale_to_metres=UNIT_SCALE[unit],
                 up_axis_guess=up_guess, up_axis_applied=up)
    if rig is not None:
        assert doc is not None and world is not None, "a rig comes from a glTF document"
        rig = _source_rig(doc, rig, world, conversion, vertices)
        stats["input_skeleton_joints"] = rig.skeleton.num_joints
    if doc is not None and doc.dropped_images:
        stats["external_images_dropped"] = list(doc.dropped_images)
    stats["warnings"] = warnings
    return IngestedMesh(vertices, faces, glb, UNIT_SCALE[unit], rig, doc, stats)


def _dropped_images_message(uris: list[str]) -> str:
    """The warning for texture images that pointed at files outside the upload."""
    shown = ", ".join(repr(u[:80]) for u in uris[:3]) + (f" and {len(uris) - 3} more" if len(uris) > 3 else "")
    return (f"{len(uris)} texture image(s) point at files outside the upload and were left out unread ({shown}); "
            "the mesh is rigged without them. Upload a GLB with embedded textures, or a .zip of the .gltf with its "
            ".bin and images, to keep them")


def run(state: PipelineState, progress: StageProgress) -> None:
    """Pipeline stage: ingest the uploaded mesh, write mesh.glb and the mesh section of the report."""
    data = Path(state.inputs.mesh_path).read_bytes()
    progress(0.1)
    opts = state.options
    import os

    max_vertices = int(os.environ.get("RIGFORGE_MAX_VERTICES", DEFAULT_MAX_VERTICES))
    from simcore.motion_rig.upload import read_sequence_upload, sequence_in_mesh_frame

    fmt = state.inputs.mesh_format
    sequence = read_sequence_upload(data, fmt, opts.motion.fps, required=opts.skeleton == "from_motion")
    if sequence is not None:  # the bind mesh is the sequence's own mesh (a zip of frames: its first frame)
        data, fmt = sequence.mesh_data, sequence.mesh_format
    state.mesh = ingest(data, fmt, up_axis=opts.up_axis, units=opts.units, max_vertices=max_vertices)
    if sequence is not None:
        state.mesh_sequence = sequence_in_mesh_frame(sequence.sequence, state.mesh)
    (state.workdir / "mesh.glb").write_bytes(state.mesh.glb)
    state.artifacts["mesh.glb"] = state.workdir / "mesh.glb"
    stats = dict(state.mesh.stats)
    for w in stats.pop("warnings", []):
        state.warn(w)
    dropped = stats.get("external_images_dropped", [])
    if dropped:
        state.warn(_dropped_images_message(dropped), code="external_images_dropped", figure=len(dropped))
    state.report["mesh"] = stats
    progress(1.0)
