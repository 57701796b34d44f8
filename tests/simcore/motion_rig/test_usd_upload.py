"""USD mesh-sequence uploads (time-sampled points): read in frame order in the mesh's frame, and refused clearly when
broken (topology that changes, NaN, no animation, other files referred to, over the caps)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from simcore.errors import InvalidInput, LimitExceeded
from simcore.evaluation.motion_sequences import tube_sequence
from simcore.ingest import ingest
from simcore.io.sniff import require_kind, sniff
from simcore.motion_rig import upload
from simcore.motion_rig.upload import is_sequence_archive, read_sequence_upload, sequence_in_mesh_frame


def usd_sequence(path: Path, frames: np.ndarray, faces: np.ndarray, *, up: str = "Y", metres: float = 1.0,
                 fps: float = 24.0, times: np.ndarray | None = None, left_handed: bool = False,
                 quads: bool = False, offset: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> Path:
    """A USD stage (format from `path`'s suffix) with one mesh whose points are sampled at `times` (default
    0, 1, ...). quads: `faces` are (Q, 4) quads. offset: a translation on the mesh's parent transform."""
    from pxr import Gf, Usd, UsdGeom, Vt

    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z if up == "Z" else UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, metres)
    stage.SetTimeCodesPerSecond(fps)
    xform = UsdGeom.Xform.Define(stage, "/Root")
    xform.AddTranslateOp().Set(Gf.Vec3d(*offset))
    mesh = UsdGeom.Mesh.Define(stage, "/Root/Body")
    counts, indices = [faces.shape[1]] * len(faces), [int(i) for i in faces.reshape(-1)]
    if left_handed:
        mesh.GetOrientationAttr().Set(UsdGeom.Tokens.leftHanded)
        indices = [i for k in range(0, len(indices), counts[0]) for i in reversed(indices[k:k + counts[0]])]
    mesh.GetFaceVertexCountsAttr().Set(Vt.IntArray(counts))
    mesh.GetFaceVertexIndicesAttr().Set(Vt.IntArray(indices))
    times = np.arange(len(frames), dtype=np.float64) if times is None else times
    for t, pts in zip(times.tolist(), frames):
        mesh.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(np.asarray(pts, np.float32)), Usd.TimeCode(t))
    stage.SetStartTimeCode(float(times[0]))
    stage.SetEndTimeCode(float(times[-1]))
    stage.GetRootLayer().Save()
    return path


@pytest.fixture(scope="module")
def tube():
    return tube_sequence(6, 6, 2, 12, seed=1)


def _read(path: Path, fps: float | None = None):
    data = path.read_bytes()
    fmt = sniff(data[:4096], len(data))
    return read_sequence_upload(data, require_kind(fmt, "mesh", "mesh"), fps)


@pytest.mark.parametrize("suffix", [".usdc", ".usda"])
def test_usd_points_read_in_frame_order_in_the_mesh_frame(tube, tmp_path, suffix):
    seq = _read(usd_sequence(tmp_path / f"tube{suffix}", tube.frames, tube.faces, fps=30.0))
    assert seq is not None and seq.mesh_format == "obj" and seq.sequence.fps == pytest.approx(30.0)
    assert np.array_equal(seq.sequence.faces, tube.faces)
    mesh = ingest(seq.mesh_data, seq.mesh_format, units="m")
    moved = sequence_in_mesh_frame(seq.sequence, mesh)
    assert moved.frames.shape == tube.frames.shape
    assert np.allclose(moved.frames, tube.frames, atol=1e-5)
    assert np.allclose(mesh.vertices, tube.frames[0], atol=1e-5)


def _face_normals(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    return np.cross(points[faces[:, 1]] - points[faces[:, 0]], points[faces[:, 2]] - points[faces[:, 0]])


def test_z_up_centimetres_quads_and_transforms_come_out_y_up_metres(tube, tmp_path):
    half = len(tube.faces) // 2  # tube triangles (a, b, a+n) and (b, b+n, a+n) of each quad
    quads = np.stack([tube.faces[:half, 0], tube.faces[:half, 1], tube.faces[half:, 1], tube.faces[:half, 2]], 1)
    z_up = tube.frames @ np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]).T * 100.0  # (x, y, z) → (x, -z, y), in cm
    path = usd_sequence(tmp_path / "z.usdc", z_up - [0.0, 0.0, 50.0], quads, up="Z", metres=0.01, left_handed=True,
                        offset=(0.0, 0.0, 50.0))
    seq = _read(path)
    assert seq is not None
    assert np.allclose(seq.sequence.frames, tube.frames, atol=1e-5)
    assert len(seq.sequence.faces) == len(tube.faces)  # each quad fans into two triangles
    rest = tube.frames[0]
    vertex_normals = np.zeros_like(rest)
    np.add.at(vertex_normals, tube.faces.reshape(-1), np.repeat(_face_normals(rest, tube.faces), 3, axis=0))
    out = seq.sequence.faces
    agree = (_face_normals(rest, out) * vertex_normals[out].sum(1)).sum(1)
    assert (agree > 0).all()  # left-handed winding read as the right-handed surface it is


def test_usd_resampled_at_a_requested_rate(tube, tmp_path):
    path = usd_sequence(tmp_path / "t.usdc", tube.frames, tube.faces, fps=24.0, times=np.arange(12) * 2.0)
    own = _read(path)
    assert own is not None and len(own.sequence.frames) == 12 and own.sequence.fps == pytest.approx(12.0)
    resampled = _read(path, fps=24.0)
    assert resampled is not None and len(resampled.sequence.frames) == 23 and resampled.sequence.fps == 24.0
    assert np.allclose(resampled.sequence.frames[1], 0.5 * (tube.frames[0] + tube.frames[1]), atol=1e-5)


def test_usdz_package_reads_and_passes_the_api_structure_check(tube, tmp_path):
    from pxr import UsdUtils

    layer = usd_sequence(tmp_path / "tube.usdc", tube.frames, tube.faces)
    package = tmp_path / "tube.usdz"
    assert UsdUtils.CreateNewUsdzPackage(str(layer), str(package))
    data = package.read_bytes()
    assert sniff(data[:4096], len(data)) == "zip" and is_sequence_archive(data)
    seq = read_sequence_upload(data, "zip")
    assert seq is not None and np.allclose(seq.sequence.frames, tube.frames, atol=1e-5)


def test_points_that_change_count_are_a_topology_mismatch(tube, tmp_path):
    from pxr import Usd, UsdGeom, Vt

    path = usd_sequence(tmp_path / "t.usdc", tube.frames, tube.faces)
    stage = Usd.Stage.Open(str(path))
    UsdGeom.Mesh.Get(stage, "/Root/Body").GetPointsAttr().Set(
        Vt.Vec3fArray.FromNumpy(tube.frames[5, :-3].astype(np.float32)), Usd.TimeCode(5))
    stage.GetRootLayer().Save()
    with pytest.raises(InvalidInput) as err:
        _read(path)
    assert err.value.code == "sequence_topology_mismatch" and err.value.field == "mesh"


def test_faces_authored_as_time_samples_are_read(tube, tmp_path):
    from pxr import Usd, UsdGeom, Vt

    path = usd_sequence(tmp_path / "t.usdc", tube.frames, tube.faces)
    stage = Usd.Stage.Open(str(path))
    mesh = UsdGeom.Mesh.Get(stage, "/Root/Body")
    for attr in (mesh.GetFaceVertexCountsAttr(), mesh.GetFaceVertexIndicesAttr()):  # samples only, no default
        value = attr.Get()
        attr.Clear()
        for t in range(len(tube.frames)):
            attr.Set(Vt.IntArray(list(value)), Usd.TimeCode(t))
    stage.GetRootLayer().Save()
    seq = _read(path)
    assert seq is not None and np.array_equal(seq.sequence.faces, tube.faces)


def test_nan_points_are_refused(tube, tmp_path):
    frames = tube.frames.copy()
    frames[4, 2, 0] = np.nan
    seq = _read(usd_sequence(tmp_path / "t.usdc", frames, tube.faces))
    assert seq is not None
    mesh = ingest(seq.mesh_data, seq.mesh_format, units="m")
    with pytest.raises(InvalidInput) as err:
        sequence_in_mesh_frame(seq.sequence, mesh)
    assert err.value.code == "non_finite" and "frame 4" in str(err.value)


def test_a_usd_without_animated_points_is_no_sequence(tube, tmp_path):
    with pytest.raises(InvalidInput) as err:
        _read(usd_sequence(tmp_path / "still.usdc", tube.frames[:1], tube.faces))
    assert err.value.code == "no_mesh_sequence" and err.value.field == "mesh"


def test_a_usd_that_refers_to_other_files_is_refused(tube, tmp_path):
    from pxr import Usd

    usd_sequence(tmp_path / "inner.usdc", tube.frames, tube.faces)
    stage = Usd.Stage.CreateNew(str(tmp_path / "outer.usda"))
    stage.DefinePrim("/Rig").GetReferences().AddReference(str(tmp_path / "inner.usdc"), "/Root")
    stage.GetRootLayer().Save()
    with pytest.raises(InvalidInput) as err:
        _read(tmp_path / "outer.usda")
    assert err.value.code == "usd_external_reference"


def test_broken_usd_bytes_are_a_clear_error():
    with pytest.raises(InvalidInput) as err:
        read_sequence_upload(b"PXR-USDC" + b"\x00" * 200, "usd")
    assert err.value.code == "unreadable_mesh"


def test_usd_caps_hold_before_the_frames_are_read(tube, tmp_path, monkeypatch):
    path = usd_sequence(tmp_path / "t.usdc", tube.frames, tube.faces)
    monkeypatch.setattr(upload, "MAX_SAMPLES", 5 * len(tube.rest))
    with pytest.raises(LimitExceeded) as err:
        _read(path)
    assert err.value.code == "sequence_too_large"
    monkeypatch.setattr(upload, "MAX_FRAMES", 5)
    with pytest.raises(LimitExceeded) as err2:
        _read(path)
    assert err2.value.code == "sequence_too_large"
