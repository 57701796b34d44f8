"""A mesh sequence from USD (.usd/.usda/.usdc/.usdz) whose meshes carry time-sampled points (usd-core `pxr`).

Every mesh of the stage (default or render purpose) is read at each frame time in world space (its animated
transforms applied), concatenated in stage order, and brought to +Y up metres by the stage's `upAxis` and
`metersPerUnit`. Frames are the points' own time samples, or a resampling at `fps` over their range. The file
must be self-contained: references, payloads, sublayers and value clips are refused (an upload must not make
the worker read other files). Topology (face counts and indices, point count) must be the same in every frame.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from typing import Any

import numpy as np

from simcore.errors import InvalidInput
from simcore.io.gltf_morph_sequence import MeshSequence

_Z_UP_TO_Y = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])  # (x, y, z) → (x, z, -y)


def _fail(message: str, code: str = "unreadable_mesh") -> InvalidInput:
    return InvalidInput(message, code=code, field="mesh")


def _open_stage(path: str) -> Any:  # noqa: ANN401 - pxr has no stubs
    from pxr import Sdf, Tf, Usd

    try:
        layer = Sdf.Layer.FindOrOpen(path)
    except Tf.ErrorException as exc:
        raise _fail(f"the USD file could not be read: {str(exc).strip()[:300]}") from exc
    if layer is None:
        raise _fail("the USD file could not be read")
    if layer.GetCompositionAssetDependencies() or layer.externalReferences:
        raise _fail("a USD upload must be self-contained: it refers to other files (references, payloads or "
                    "sublayers)", "usd_external_reference")
    try:
        stage = Usd.Stage.Open(layer, Usd.Stage.LoadAll)
    except Tf.ErrorException as exc:
        raise _fail(f"the USD stage could not be composed: {str(exc).strip()[:300]}") from exc
    return stage


def _meshes(stage: Any) -> list[Any]:  # noqa: ANN401
    from pxr import Usd, UsdGeom

    found = []
    for prim in Usd.PrimRange(stage.GetPseudoRoot()):
        if prim.HasMetadata("clips") and prim.GetMetadata("clips"):
            raise _fail("a USD upload must be self-contained: it uses value clips (other files)",
                        "usd_external_reference")
        if prim.IsA(UsdGeom.Mesh) and UsdGeom.Imageable(prim).ComputePurpose() in (UsdGeom.Tokens.default_,
                                                                                    UsdGeom.Tokens.render):
            found.append(UsdGeom.Mesh(prim))
    if not found:
        raise _fail("the USD file holds no mesh", "empty_mesh")
    return found


def _triangles(mesh: Any, points: int) -> np.ndarray:  # noqa: ANN401
    """(F, 3) int64 fan triangulation of the mesh's polygons (right-handed winding)."""
    from pxr import Usd, UsdGeom

    counts_attr, index_attr = mesh.GetFaceVertexCountsAttr(), mesh.GetFaceVertexIndicesAttr()
    for attr in (counts_attr, index_attr):
        samples = attr.GetTimeSamples()
        if len(samples) > 1:
            first = np.asarray(attr.Get(samples[0]))
            if any(not np.array_equal(np.asarray(attr.Get(t)), first) for t in samples[1:]):
                raise _fail(f"{mesh.GetPath()} changes its faces over time: every frame must keep one topology",
                            "sequence_topology_mismatch")
    first = Usd.TimeCode.EarliestTime()  # the default value, or the first sample of a time-sampled topology
    counts = np.asarray(counts_attr.Get(first) or [], np.int64)
    indices = np.asarray(index_attr.Get(first) or [], np.int64)
    if len(counts) == 0 or counts.min() < 3 or counts.sum() != len(indices):
        raise _fail(f"{mesh.GetPath()} has malformed faces (a face with under 3 corners, or counts that do not "
                    "match the indices)")
    if indices.min() < 0 or indices.max() >= points:
        raise _fail(f"a face of {mesh.GetPath()} refers to a point that does not exist", "index_out_of_range")
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    fan = np.repeat(starts, counts - 2)
    step = np.arange(len(fan)) - np.repeat(np.cumsum(counts - 2) - (counts - 2), counts - 2)
    tri = np.stack([indices[fan], indices[fan + step + 1], indices[fan + step + 2]], axis=1)
    if mesh.GetOrientationAttr().Get() == UsdGeom.Tokens.leftHanded:
        tri = tri[:, ::-1]
    return np.ascontiguousarray(tri)


def _frame_times(meshes: list[Any], fps: float | None, codes_per_second: float,  # noqa: ANN401
                 check_frames: Callable[[int], None]) -> tuple[np.ndarray, float]:
    """Time codes of the frames and their rate: the points' own samples, or `fps` over their range."""
    samples = sorted({t for m in meshes for t in m.GetPointsAttr().GetTimeSamples()})
    if len(samples) < 2:
        return np.asarray(samples, np.float64), fps or codes_per_second
    if fps is None:
        step = float(np.median(np.diff(samples)))
        check_frames(len(samples))
        return np.asarray(samples, np.float64), codes_per_second / step
    count = int(np.floor((samples[-1] - samples[0]) * fps / codes_per_second + 1e-9)) + 1
    check_frames(count)
    return samples[0] + np.arange(count) * codes_per_second / fps, float(fps)


def read_usd_sequence(data: bytes, suffix: str, *, fps: float | None, check_frames: Callable[[int], None],
                      check_samples: Callable[[int, int], None]) -> MeshSequence | None:
    """The frames (T, V, 3) float64 (+Y up, metres), faces and rate of a USD upload; None when no mesh of it has
    time-sampled points. suffix: ".usd" (text or crate) or ".usdz". check_frames / check_samples: the caller's
    caps, applied before the frames are read. Raises InvalidInput for unreadable or inconsistent files."""
    from pxr import Usd, UsdGeom

    handle, path = tempfile.mkstemp(suffix=suffix)
    try:
        with os.fdopen(handle, "wb") as out:
            out.write(data)
        stage = _open_stage(path)
        meshes = _meshes(stage)
        codes_per_second = float(stage.GetTimeCodesPerSecond()) or 24.0
        times, rate = _frame_times(meshes, fps, codes_per_second, check_frames)
        if len(times) < 2:
            return None
        sizes = [len(m.GetPointsAttr().Get(times[0]) or []) for m in meshes]
        check_samples(len(times), sum(sizes))
        faces = np.concatenate([_triangles(m, n) + off for m, n, off in zip(meshes, sizes, np.cumsum([0, *sizes]))])
        frames = np.empty((len(times), sum(sizes), 3))
        for t, time in enumerate(times.tolist()):
            cache, parts = UsdGeom.XformCache(Usd.TimeCode(time)), []
            for mesh, size in zip(meshes, sizes):
                pts = mesh.GetPointsAttr().Get(Usd.TimeCode(time))
                pts = np.asarray(pts if pts is not None else [], np.float64).reshape(-1, 3)
                if len(pts) != size:
                    raise _fail(f"{mesh.GetPath()} has {len(pts)} points at time {time:g} and {size} at the first "
                                "frame: every frame must keep one topology", "sequence_topology_mismatch")
                world = np.array(cache.GetLocalToWorldTransform(mesh.GetPrim()), np.float64)  # row vectors
                parts.append(pts @ world[:3, :3] + world[3, :3])
            frames[t] = np.concatenate(parts)
        z_up = UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z
        metres = float(UsdGeom.GetStageMetersPerUnit(stage)) or 1.0
    finally:
        os.unlink(path)
    if z_up:
        frames = frames @ _Z_UP_TO_Y.T
    frames *= metres
    name = meshes[0].GetPrim().GetName()
    return MeshSequence(frames, faces.astype(np.int64), float(rate), name)
