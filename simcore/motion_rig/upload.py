"""Mesh-sequence uploads: a glTF morph-target animation (no skin), a .zip of per-frame OBJ/PLY files, or USD
(.usd/.usda/.usdc, or a .usdz package) whose meshes have time-sampled points (simcore.io.usd_mesh_sequence).

`read_sequence_upload` says whether an upload is a sequence and, when it is, which bytes are the bind mesh that
ingest reads and the frames in the file's own frame; `sequence_in_mesh_frame` checks the frames against the
ingested mesh and brings them into its frame (metres, +Y up).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from simcore.errors import InvalidInput, LimitExceeded
from simcore.geometry.mesh import IngestedMesh
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_morph_sequence import MeshSequence, read_morph_sequence

MAX_FRAMES = 10_000
MAX_SAMPLES = 20_000_000  # frames × vertices: the solver holds a few (T, V, 3) float64 arrays
FRAME_SUFFIXES = {".obj": "obj", ".ply": "ply"}
USD_SUFFIXES = (".usd", ".usda", ".usdc")


@dataclass
class SequenceUpload:
    """mesh_data/mesh_format: the bind mesh to ingest (the upload itself, or its first frame);
    sequence: the frames (T, V, 3) float64 in the file's coordinates, with faces and fps."""

    mesh_data: bytes
    mesh_format: str
    sequence: MeshSequence


def _has_morph_animation(doc: GltfDocument) -> bool:
    """A glTF without a skin whose first animation drives morph weights (what read_morph_sequence reads)."""
    anims = doc.items("animations")
    if not anims or any("skin" in n for n in doc.items("nodes")):
        return False
    return any(c.get("target", {}).get("path") == "weights" for c in anims[0].get("channels", []))


def _natural_key(name: str) -> list:
    """frame_2 before frame_10."""
    return [int(p) if p.isdigit() else p.lower() for p in re.split(r"(\d+)", name)]


def _frame_files(data: bytes) -> list[tuple[str, bytes, str]] | None:
    """(name, bytes, format) of a .zip holding per-frame OBJ or PLY files only, in natural name order."""
    from simcore.io.gltf_zip import ZipArchive

    archive = ZipArchive(data)
    names = [n for n in archive.files if not n.lower().endswith(".mtl") and "__MACOSX" not in n]
    kinds = {FRAME_SUFFIXES.get(n[n.rfind("."):].lower()) for n in names}
    if not names or None in kinds or len(kinds) != 1:
        return None
    fmt = kinds.pop()
    assert fmt is not None
    return [(n, archive.read(n), fmt) for n in sorted(names, key=_natural_key)]


def _is_usdz(data: bytes) -> bool:
    """A .zip whose first member is a USD layer (a .usdz package)."""
    from simcore.io.gltf_zip import ZipArchive

    names = list(ZipArchive(data).files)
    return bool(names) and names[0].lower().endswith(USD_SUFFIXES)


def is_sequence_archive(data: bytes) -> bool:
    """A .zip that is a mesh sequence (per-frame OBJ/PLY files, or a .usdz) rather than a zipped glTF: the
    upload check leaves it to the worker's sequence reader."""
    return _is_usdz(data) or _frame_files(data) is not None


def _usd_upload(data: bytes, suffix: str, fps: float | None) -> SequenceUpload:
    """A USD sequence; its first frame, as OBJ (+Y up, metres), is the bind mesh."""
    import trimesh
    from trimesh.exchange.obj import export_obj

    from simcore.io.usd_mesh_sequence import read_usd_sequence

    sequence = read_usd_sequence(data, suffix, fps=fps, check_frames=check_frame_count, check_samples=check_samples)
    if sequence is None:
        raise InvalidInput("a USD upload must be a mesh sequence: no mesh of this file has time-sampled points "
                           "(a skeletal USD animation is not read; export its meshes' points per frame)",
                           code="no_mesh_sequence", field="mesh")
    first = trimesh.Trimesh(sequence.frames[0], sequence.faces, process=False)
    obj = export_obj(first, include_normals=False, include_color=False, include_texture=False, digits=9, header=None)
    return SequenceUpload(obj.encode(), "obj", sequence)


def _frames_from_files(files: list[tuple[str, bytes, str]], fps: float) -> MeshSequence:
    """Each file's vertices, read as ingest reads a mesh; every frame must repeat the first one's topology."""
    from simcore.ingest import _load_other

    check_frame_count(len(files))
    frames, faces = [], None
    for name, data, fmt in files:
        vertices, tri, _ = _load_other(data, fmt)
        if faces is None:
            faces = tri
        elif len(vertices) != len(frames[0]) or not np.array_equal(tri, faces):
            raise InvalidInput(f"frame {name!r} has {len(vertices)} vertices and {len(tri)} triangles; the first frame "
                               f"has {len(frames[0])} and {len(faces)}: every frame must keep one topology and vertex "
                               "order", code="sequence_topology_mismatch", field="mesh")
        frames.append(np.asarray(vertices, np.float64))
        check_samples(len(frames), len(vertices))
    assert faces is not None
    return MeshSequence(np.stack(frames), np.asarray(faces, np.int64), fps, "frames")


def check_frame_count(frames: int) -> None:
    """At least two frames (one pose shows no motion), at most MAX_FRAMES."""
    if frames < 2:
        raise InvalidInput(f"a mesh sequence needs at least 2 frames; this one has {frames}",
                           code="sequence_too_short", field="mesh")
    if frames > MAX_FRAMES:
        raise LimitExceeded(f"the mesh sequence has {frames} frames; the limit is {MAX_FRAMES}",
                            code="sequence_too_large", field="mesh")


def check_samples(frames: int, vertices: int) -> None:
    """frames × vertices within MAX_SAMPLES."""
    if frames * vertices > MAX_SAMPLES:
        raise LimitExceeded(f"the mesh sequence has {frames} frames × {vertices} vertices; the limit is "
                            f"{MAX_SAMPLES} vertex positions", code="sequence_too_large", field="mesh")


def read_sequence_upload(data: bytes, fmt: str, fps: float | None = None, *,
                         required: bool = False) -> SequenceUpload | None:
    """The upload as a mesh sequence, or None when it is a single mesh (or a rig with its own skin).

    fmt: the sniffed format (glb, gltf, zip, ...); fps: the rate of per-frame files (default 30) or a resampling
    rate for a morph animation (default: its keyframe rate). required: raise InvalidInput (no_mesh_sequence)
    rather than return None (options.skeleton "from_motion").
    """
    upload = _read_sequence_upload(data, fmt, fps)
    if upload is None and required:
        raise InvalidInput("skeleton 'from_motion' needs a mesh sequence: a glTF/GLB whose animation drives morph "
                           "targets (and that has no skin), a .zip of per-frame OBJ or PLY files, or USD with "
                           "time-sampled points",
                           code="no_mesh_sequence", field="mesh")
    return upload


def _read_sequence_upload(data: bytes, fmt: str, fps: float | None) -> SequenceUpload | None:
    if fmt in ("glb", "gltf"):
        doc = GltfDocument.from_bytes(data)
        if not _has_morph_animation(doc):
            return None
        return SequenceUpload(data, fmt, read_morph_sequence(doc, fps=fps, max_frames=MAX_FRAMES + 1))
    if fmt == "usd":
        return _usd_upload(data, ".usd", fps)
    if fmt == "zip":
        if _is_usdz(data):
            return _usd_upload(data, ".usdz", fps)
        files = _frame_files(data)
        if files is None:
            return None
        sequence = _frames_from_files(files, fps or 30.0)
        return SequenceUpload(files[0][1], files[0][2], sequence)
    return None


def sequence_in_mesh_frame(sequence: MeshSequence, mesh: IngestedMesh) -> MeshSequence:
    """The frames in the ingested mesh's frame (its units and up axis), checked against its vertices.

    Raises InvalidInput when the frames do not have the mesh's vertex count, or hold NaN/infinite values.
    """
    from simcore.ingest import conversion_matrix

    frames = sequence.frames
    check_frame_count(len(frames))
    check_samples(frames.shape[0], frames.shape[1])
    if frames.shape[1] != len(mesh.vertices):
        raise InvalidInput(f"the animated mesh has {frames.shape[1]} vertices but the file holds {len(mesh.vertices)}: "
                           "a mesh sequence upload must hold the one animated mesh only",
                           code="sequence_topology_mismatch", field="mesh")
    if not np.all(np.isfinite(frames)):
        bad = int(np.flatnonzero(~np.isfinite(frames).all(axis=(1, 2)))[0])
        raise InvalidInput(f"frame {bad} of the mesh sequence has NaN or infinite coordinates", code="non_finite",
                           field="mesh")
    stats = mesh.stats
    conversion = conversion_matrix(stats["up_axis_applied"], float(stats["scale_to_metres"]))
    moved = frames @ conversion[:3, :3].T + conversion[:3, 3]
    return MeshSequence(moved, mesh.faces, sequence.fps, sequence.name)
