"""glTF animation writing: joint rotation/translation channels and refinement morph-target weights.

Morph scheme (refined.glb): the bind-space offsets from the skinned animation are keyed at a subset of frames
(every frame, or at most `key_rate` keys per second, e.g. the simulation rate, and at most `max_targets`) and
written compactly (morph_compact): R basis shapes shared by every key plus, per key, a sparse residual target
holding only the vertices the basis misses by more than the tolerance. Targets are normalized integers
(KHR_mesh_quantization: BYTE for the basis, BYTE or SHORT for residuals, SHORT where BYTE's rounding would
exceed a quarter of the tolerance), one scale per target carried by its animated weight; residuals are sparse
accessors. Key k's weights are the basis coefficients times their scales and its own residual's scale; a
clip keyed at every frame uses a STEP sampler, otherwise LINEAR (offsets blend between neighbouring keys).
The default cap of 256 targets is the smallest MAX_ARRAY_TEXTURE_LAYERS WebGL 2 guarantees, which three.js
uses for morph target textures.
"""

from __future__ import annotations

import numpy as np

from simcore.io.glb_packer import ARRAY_BUFFER, COMPONENT_TYPES, GlbBuilder
from simcore.io.joint_tracks import joint_tracks
from simcore.motion.types import JointAnimation
from simcore.skeleton.kinematics import rest_local_matrices
from simcore.skeleton.types import Skeleton

TRANSLATION_EPS = 1e-6  # metres: a non-root joint whose translation track stays this close to rest gets no channel


def _sampler(builder: GlbBuilder, clip: dict, times: np.ndarray, values: np.ndarray, interpolation: str) -> int:
    sampler = {
        "input": builder.add_accessor(times.astype(np.float32), minmax=True),
        "output": builder.add_accessor(np.ascontiguousarray(values, dtype=np.float32)),
        "interpolation": interpolation,
    }
    clip["samplers"].append(sampler)
    return len(clip["samplers"]) - 1


def add_joint_animation(builder: GlbBuilder, skeleton: Skeleton, animation: JointAnimation, joint_base: int) -> dict:
    """Write rotation channels for every clip joint and translation channels for the root and any joint
    whose translation leaves its rest value; return the glTF animation object (not yet attached).

    joint_base: node index of joint 0 (joints are consecutive nodes in skeleton order).
    """
    tracks = joint_tracks(skeleton, animation)
    clip: dict = {"name": animation.name, "channels": [], "samplers": []}
    times_acc = builder.add_accessor(tracks.times.astype(np.float32), minmax=True)
    rest_local = rest_local_matrices(skeleton)[:, :3, 3]
    for j in np.flatnonzero(tracks.animated):
        rot = tracks.rotations[:, j].astype(np.float32)
        rot /= np.linalg.norm(rot, axis=1, keepdims=True)  # unit length in float32, as the validator checks
        channels = [("rotation", rot)]
        moved = np.abs(tracks.translations[:, j] - rest_local[j]).max() > TRANSLATION_EPS
        if skeleton.parents[j] < 0 or moved:
            channels.append(("translation", tracks.translations[:, j]))
        for path, values in channels:
            clip["samplers"].append({
                "input": times_acc,
                "output": builder.add_accessor(np.ascontiguousarray(values, dtype=np.float32)),
                "interpolation": "LINEAR",
            })
            clip["channels"].append({"sampler": len(clip["samplers"]) - 1,
                                     "target": {"node": joint_base + int(j), "path": path}})
    return clip


QUANTIZATION = "KHR_mesh_quantization"
BASIS_LEVELS = 127  # basis shapes as normalized BYTE
BASIS_VERTEX_BYTES = 4.0  # a BYTE VEC3 vertex attribute element, padded to 4 bytes
RESIDUAL_VERTEX_BYTES = 5.0  # a sparse BYTE VEC3 value and its UNSIGNED_SHORT index


def morph_key_frames(frame_count: int, max_targets: int, fps: float | None = None,
                     key_rate: float | None = None) -> np.ndarray:
    """(K,) int64 frames that get a key: all of them, or (with key_rate below fps) the frames nearest every
    1 / key_rate seconds, and the last; at most `max_targets`, then spread uniformly over the clip."""
    frames = np.arange(frame_count)
    if key_rate is not None and fps is not None and 0 < key_rate < fps and frame_count > 1:
        step = fps / key_rate
        frames = np.unique(np.append(np.round(np.arange(0.0, frame_count - 1, step)).astype(np.int64), frame_count - 1))
    if len(frames) <= max_targets:
        return frames
    return np.unique(np.round(np.linspace(0, frame_count - 1, max_targets)).astype(np.int64))


def _quantized_dense(builder: GlbBuilder, q: np.ndarray) -> int:
    """A normalized integer VEC3 vertex attribute accessor, elements padded to 4-byte multiples."""
    width = q.dtype.itemsize * 4 if q.dtype.itemsize * 3 % 4 else q.dtype.itemsize * 3
    padded = np.zeros((len(q), width // q.dtype.itemsize), q.dtype)
    padded[:, :3] = q
    view = builder.add_view(padded.tobytes(), ARRAY_BUFFER)
    builder.json["bufferViews"][view]["byteStride"] = width
    return builder.add("accessors", {
        "bufferView": view, "componentType": COMPONENT_TYPES[q.dtype], "normalized": True, "count": len(q),
        "type": "VEC3", "min": [int(x) for x in q.min(axis=0)], "max": [int(x) for x in q.max(axis=0)]})


def _quantized_sparse(builder: GlbBuilder, count: int, rows: np.ndarray, q: np.ndarray, dtype: np.dtype) -> int:
    """A normalized integer VEC3 accessor of `count` zeros but at ascending `rows` (n,), where it holds q (n, 3)."""
    acc: dict = {"componentType": COMPONENT_TYPES[np.dtype(dtype)], "normalized": True, "count": count, "type": "VEC3"}
    full_min, full_max = np.zeros(3, np.int64), np.zeros(3, np.int64)
    if len(rows):
        idx_dtype = np.uint8 if count <= 256 else np.uint16 if count <= 65536 else np.uint32
        acc["sparse"] = {"count": len(rows),
                         "indices": {"bufferView": builder.add_view(rows.astype(idx_dtype).tobytes()),
                                     "componentType": COMPONENT_TYPES[np.dtype(idx_dtype)]},
                         "values": {"bufferView": builder.add_view(np.ascontiguousarray(q, dtype).tobytes())}}
        full_min, full_max = q.min(axis=0).astype(np.int64), q.max(axis=0).astype(np.int64)
        if len(rows) < count:  # the other elements are zeros
            full_min, full_max = np.minimum(full_min, 0), np.maximum(full_max, 0)
    acc["min"], acc["max"] = [int(x) for x in full_min], [int(x) for x in full_max]
    return builder.add("accessors", acc)


def _use_quantization(builder: GlbBuilder) -> None:
    for key in ("extensionsUsed", "extensionsRequired"):
        names = builder.json.setdefault(key, [])
        if QUANTIZATION not in names:
            names.append(QUANTIZATION)


def add_morph_animation(builder: GlbBuilder, clip: dict, slices: list, offsets: np.ndarray, frames: np.ndarray,
                        frame_count: int, fps: float, max_targets: int = 256, *, tolerance: float = 0.0) -> dict:
    """Add the refinement's morph targets to every primitive and a weights channel per mesh node.

    slices:    PrimitiveSlice list (mesh, primitive, start, count) in vertex order; mesh m's node is node m.
    offsets:   (K, V, 3) float bind-space vertex offsets at the key frames (K,) (`morph_key_frames` of the
               clip's frame_count frames; frame f at time f / fps).
    tolerance: largest vertex error the compact form may add (offset units, see morph_compact); the residuals'
               rounding adds at most a quarter of it.
    The upload's own targets (blend shapes) stay first and keep their default weights throughout the clip.
    Returns JSON-ready stats (keys, basis shapes, residual vertices, targets, interpolation, errors, bytes).
    """
    from simcore.io.morph_compact import compact_offsets, quantize

    start_bytes = len(builder.binary)
    compact = compact_offsets(offsets, tolerance, BASIS_VERTEX_BYTES, RESIDUAL_VERTEX_BYTES,
                              basis_levels=BASIS_LEVELS, max_shapes=max_targets)
    k, rank = len(frames), compact.rank
    # basis: one BYTE target per shape; weight = coefficient × the shape's scale
    basis_q = [quantize(b, BASIS_LEVELS) for b in compact.basis]
    # residuals: keys with kept vertices get a target; BYTE unless its rounding exceeds a quarter of the tolerance
    residual_keys = [i for i in range(k) if len(compact.residual_rows[i])]
    residual_q = []
    quant_error = 0.0
    for i in residual_keys:
        scale = float(np.abs(compact.residual_values[i]).max())
        levels = 127 if np.sqrt(3) * scale / 254 <= 0.25 * tolerance else 32767
        q, scale = quantize(compact.residual_values[i], levels)
        residual_q.append((q, scale, levels))
        err = np.linalg.norm(q.astype(np.float64) / levels * scale - compact.residual_values[i], axis=1).max()
        quant_error = max(quant_error, float(err))
    if rank or residual_keys:
        _use_quantization(builder)
    meshes = builder.json["meshes"]
    for s in slices:
        prim = meshes[s.mesh]["primitives"][s.primitive]
        lo, hi = s.start, s.start + s.count
        targets = [{"POSITION": _quantized_dense(builder, q[lo:hi])} for q, _ in basis_q]
        for i, (q, _, _) in zip(residual_keys, residual_q):
            rows = compact.residual_rows[i]
            inside = (rows >= lo) & (rows < hi)
            targets.append({"POSITION": _quantized_sparse(builder, s.count, rows[inside] - lo, q[inside], q.dtype)})
        if targets:
            prim["targets"] = prim.get("targets", []) + targets
    names = [f"refine_basis_{j}" for j in range(rank)] + [f"frame_{int(frames[i])}" for i in residual_keys]
    weights = np.zeros((k, rank + len(residual_keys)), np.float32)
    weights[:, :rank] = compact.coefficients * np.array([sc for _, sc in basis_q])[None]
    for col, (i, (_, scale, _)) in enumerate(zip(residual_keys, residual_q)):
        weights[i, rank + col] = scale
    interpolation = "STEP" if k == frame_count else "LINEAR"
    times = np.asarray(frames) / float(fps)
    for m in sorted({s.mesh for s in slices}) if weights.shape[1] else []:  # no offsets at all: no channel
        own = [float(w) for w in meshes[m].get("weights", [])]
        own_names = meshes[m].get("extras", {}).get("targetNames", [])  # ingest names every upload target
        meshes[m]["weights"] = own + [0.0] * weights.shape[1]
        meshes[m].setdefault("extras", {})["targetNames"] = own_names + names  # three.js morphTargetDictionary keys
        # each key: the upload's own shapes at their defaults, then the refinement's weights
        values = np.hstack([np.tile(np.asarray(own, np.float32), (k, 1)), weights]).reshape(-1)
        sampler = _sampler(builder, clip, times, values, interpolation)
        clip["channels"].append({"sampler": sampler, "target": {"node": m, "path": "weights"}})
    return {"keys": k, "frames": int(frame_count), "basis_shapes": rank, "residual_targets": len(residual_keys),
            "residual_vertices": compact.residual_count(), "targets": rank + len(residual_keys),
            "interpolation": interpolation, "max_offset": float(np.abs(offsets).max(initial=0.0)),
            "tolerance": round(tolerance, 9), "max_error": round(compact.max_error + quant_error, 9),
            "bytes": len(builder.binary) - start_bytes}
