"""Mesh-sequence uploads: what reads as a sequence, and the clear errors for broken ones."""

import io
import zipfile

import numpy as np
import pytest
import trimesh

from simcore.errors import InvalidInput, LimitExceeded
from simcore.evaluation.motion_sequences import tube_sequence
from simcore.ingest import ingest
from simcore.motion_rig import upload
from simcore.motion_rig.upload import read_sequence_upload, sequence_in_mesh_frame


def exported(mesh: trimesh.Trimesh, fmt: str) -> bytes:
    """The mesh as a file of format `fmt` (trimesh types export() for every format; these give text or bytes)."""
    data = mesh.export(file_type=fmt)
    assert isinstance(data, (bytes, str))
    return data.encode() if isinstance(data, str) else data


def frames_zip(frames: np.ndarray, faces: np.ndarray, fmt: str = "obj") -> bytes:
    """A .zip of one OBJ/PLY per frame, named so that plain sorting would misorder them (frame_10 < frame_2)."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as archive:
        for t, vertices in enumerate(frames):
            archive.writestr(f"seq/frame_{t}.{fmt}", exported(trimesh.Trimesh(vertices, faces, process=False), fmt))
    return buf.getvalue()


@pytest.fixture(scope="module")
def tube():
    return tube_sequence(6, 6, 2, 12, seed=1)


@pytest.mark.parametrize("fmt", ["obj", "ply"])
def test_zip_of_frames_reads_in_frame_order_in_the_mesh_frame(tube, fmt):
    seq = read_sequence_upload(frames_zip(tube.frames, tube.faces, fmt), "zip")
    assert seq is not None and seq.mesh_format == fmt
    mesh = ingest(seq.mesh_data, seq.mesh_format, up_axis="y", units="m")
    moved = sequence_in_mesh_frame(seq.sequence, mesh)
    assert moved.frames.shape == tube.frames.shape
    assert np.allclose(moved.frames, tube.frames, atol=1e-5)  # frame_10 after frame_9, not after frame_1


def test_a_static_mesh_is_no_sequence_unless_one_is_required(tube):
    glb = exported(trimesh.Trimesh(tube.rest, tube.faces, process=False), "glb")
    assert read_sequence_upload(glb, "glb") is None
    with pytest.raises(InvalidInput) as err:
        read_sequence_upload(glb, "glb", required=True)
    assert err.value.code == "no_mesh_sequence" and err.value.field == "mesh"


def test_frames_must_keep_one_topology(tube):
    data = frames_zip(tube.frames, tube.faces)
    buf = io.BytesIO()
    with zipfile.ZipFile(io.BytesIO(data)) as src, zipfile.ZipFile(buf, "w") as dst:
        for name in src.namelist():
            dst.writestr(name, src.read(name))
        extra = trimesh.Trimesh(tube.rest, tube.faces[:-2], process=False)
        dst.writestr("seq/frame_99.obj", exported(extra, "obj"))
    with pytest.raises(InvalidInput) as err:
        read_sequence_upload(buf.getvalue(), "zip")
    assert err.value.code == "sequence_topology_mismatch"


def test_one_frame_is_too_short_and_caps_hold(tube, monkeypatch):
    with pytest.raises(InvalidInput) as err:
        read_sequence_upload(frames_zip(tube.frames[:1], tube.faces), "zip")
    assert err.value.code == "sequence_too_short"
    monkeypatch.setattr(upload, "MAX_SAMPLES", 5 * len(tube.rest))
    with pytest.raises(LimitExceeded) as err2:
        read_sequence_upload(frames_zip(tube.frames, tube.faces), "zip")
    assert err2.value.code == "sequence_too_large"


def test_non_finite_frames_are_refused(tube):
    seq = read_sequence_upload(frames_zip(tube.frames, tube.faces), "zip")
    assert seq is not None
    mesh = ingest(seq.mesh_data, seq.mesh_format, up_axis="y", units="m")
    seq.sequence.frames[3, 5, 1] = np.nan
    with pytest.raises(InvalidInput) as err:
        sequence_in_mesh_frame(seq.sequence, mesh)
    assert err.value.code == "non_finite" and "frame 3" in str(err.value)


def test_dev_morph_sequence_reads_with_the_ingested_vertices(dev_assets):
    data = (dev_assets / "meshseq_flamingo.glb").read_bytes()
    seq = read_sequence_upload(data, "glb")
    assert seq is not None
    mesh = ingest(seq.mesh_data, seq.mesh_format)
    moved = sequence_in_mesh_frame(seq.sequence, mesh)
    assert moved.frames.shape[1] == len(mesh.vertices) and len(moved.frames) >= 2
    extent = np.ptp(moved.frames[0], axis=0).max()
    assert 0.05 < extent < 20  # brought to metres with the mesh
