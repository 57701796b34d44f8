"""Hostile OBJ, PLY, STL and BVH uploads: lying counts, bad numbers, bad indices, polygon and hierarchy bombs."""

from __future__ import annotations

import struct
from collections.abc import Iterator

import numpy as np

from tests.hostile.case import OK, Case, case
from tests.simcore.motion.motion_samples import SMALL_BVH as BVH_OK

UNREADABLE = ("unreadable_mesh", "empty_mesh", "index_out_of_range", "non_finite", "unknown_format")
OBJ_TRI = "v 0 0 0\nv 1 0 0\nv 0 1 0\n"


def _ngon(n: int, planar: bool) -> str:
    rng = np.random.default_rng(n)
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    pts = np.stack([np.cos(t), np.sin(t), np.zeros(n)], 1) if planar else rng.random((n, 3))
    return "".join(f"v {x:.3f} {y:.3f} {z:.3f}\n" for x, y, z in pts) + "f " + " ".join(map(str, range(1, n + 1))) + "\n"


def obj_cases() -> Iterator[Case]:
    yield case("obj-valid", "mesh", OBJ_TRI + "f 1 2 3\n", OK)
    yield case("obj-valid-quad", "mesh", OBJ_TRI + "v 1 1 0\nf 1 2 4 3\n", OK)
    yield case("obj-valid-negative-index", "mesh", OBJ_TRI + "f -3 -2 -1\n", OK)
    for k, face in enumerate(["f 1 2 9", "f 0 1 2", "f -9 1 2", "f 1 2 99999999999999999999", "f a b c", "f 1 2",
                              "f 1/1/1 2/2/2 3/3/3", "f 1//9 2//9 3//9", "f 1 1 1", "f 1.5 2 3", "f 1 2 3 9 10"]):
        yield case(f"obj-face-{k}", "mesh", OBJ_TRI + face + "\n", OK, *UNREADABLE)
    for k, vertex in enumerate(["v nan 0 0", "v inf 0 0", "v 1e400 0 0", "v x y z", "v 0 0", "v", "v 0 0 0 0 0 0 0 0 0 0"]):
        yield case(f"obj-vertex-{k}", "mesh", vertex + "\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", OK, *UNREADABLE)
    yield case("obj-no-faces", "mesh", OBJ_TRI, "empty_mesh", "unreadable_mesh")
    yield case("obj-only-comments", "mesh", "# nothing\n" * 10 + "v 0 0 0\n", "empty_mesh", "unreadable_mesh")
    yield case("obj-mtllib-escape", "mesh", "mtllib ../../../../etc/passwd\nusemtl x\n" + OBJ_TRI + "f 1 2 3\n", OK)
    yield case("obj-ngon-256", "mesh", _ngon(256, planar=True), OK)
    for n in (300, 10_000):
        for planar in (True, False):
            yield case(f"obj-ngon-{n}-{'planar' if planar else 'random'}", "mesh", _ngon(n, planar), "polygon_too_large")
    many = OBJ_TRI + "f 1 2 3\n" * 50_000
    yield case("obj-50k-repeated-faces", "mesh", many, OK)


PLY_HEAD = "ply\nformat ascii 1.0\nelement vertex {v}\nproperty float x\nproperty float y\nproperty float z\n" \
           "element face {f}\nproperty list uchar int vertex_indices\nend_header\n"


def _ply(v: int | str, f: int | str, body: str) -> str:
    return PLY_HEAD.format(v=v, f=f) + body


def ply_cases() -> Iterator[Case]:
    verts = "0 0 0\n1 0 0\n0 1 0\n"
    yield case("ply-valid", "mesh", _ply(3, 1, verts + "3 0 1 2\n"), OK)
    malformed: list[tuple[int | str, int, str]] = [
        (30, 1, verts + "3 0 1 2\n"), (3, 10, verts + "3 0 1 2\n"), (-1, 1, verts), (3, -5, verts),
        (10**12, 1, verts), (3, 10**12, verts), ("x", 1, verts), (3, 1, verts + "3 0 1 9\n"), (3, 1, verts + "3 0 1\n"),
        (3, 1, verts + "255 0 1 2\n"), (3, 1, "nan nan nan\n1 0 0\n0 1 0\n3 0 1 2\n"), (3, 1, "a b c\n1 0 0\n0 1 0\n3 0 1 2\n"),
        (3, 1, verts + "3 -1 0 1\n"), (3, 1, verts + "3 0 1 99999999999\n"), (3, 0, verts), (0, 0, ""),
    ]
    for k, (v, f, body) in enumerate(malformed):
        yield case(f"ply-ascii-{k}", "mesh", _ply(v, f, body), OK, *UNREADABLE, "too_many_vertices")
    header = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n" \
             "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
    good = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], "<f4").tobytes() + struct.pack("<B3i", 3, 0, 1, 2)
    yield case("ply-binary-valid", "mesh", header.encode() + good, OK)
    for n in (0, 5, 20, len(good) - 1):
        yield case(f"ply-binary-truncated-{n}", "mesh", header.encode() + good[:n], OK, *UNREADABLE)
    yield case("ply-binary-bad-index", "mesh", header.encode() + good[:-12] + struct.pack("<3i", 0, 1, 7), *UNREADABLE)
    for k, head in enumerate(["ply\nformat ascii 1.0\nend_header\n", "ply\nelement vertex 3\nend_header\n" + verts,
                              "ply\nformat klingon 1.0\nelement vertex 3\nproperty float x\nend_header\n",
                              "ply\nformat ascii 1.0\nelement vertex 3\nproperty quaternion x\nend_header\n" + verts,
                              "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"]):
        yield case(f"ply-header-{k}", "mesh", head, *UNREADABLE)


def _stl_binary(tris: np.ndarray, declared: int | None = None) -> bytes:
    count = len(tris) if declared is None else declared
    body = b"".join(struct.pack("<3f", 0, 0, 1) + t.astype("<f4").tobytes() + b"\0\0" for t in tris)
    return b"\0" * 80 + struct.pack("<I", count) + body


def stl_cases() -> Iterator[Case]:
    tri = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]]], np.float32)
    yield case("stl-binary-valid", "mesh", _stl_binary(tri), OK)
    yield case("stl-ascii-valid", "mesh", "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
                                          "endloop\nendfacet\nendsolid t\n", OK)
    yield case("stl-binary-count-lies", "mesh", _stl_binary(tri, 1000), *UNREADABLE)
    yield case("stl-binary-nan", "mesh", _stl_binary(np.full((1, 3, 3), np.nan, np.float32)), *UNREADABLE)
    yield case("stl-binary-inf", "mesh", _stl_binary(np.full((1, 3, 3), np.inf, np.float32)), *UNREADABLE)
    yield case("stl-binary-degenerate", "mesh", _stl_binary(np.zeros((4, 3, 3), np.float32)), OK, *UNREADABLE)
    for k, body in enumerate(["vertex 0 0 0\nvertex 1 0 0\n", "vertex a b c\nvertex 1 0 0\nvertex 0 1 0\n",
                              "vertex nan 0 0\nvertex 1 0 0\nvertex 0 1 0\n", "vertex 0 0\nvertex 1 0 0\nvertex 0 1 0\n",
                              "vertex 1e999 0 0\nvertex 1 0 0\nvertex 0 1 0\n", ""]):
        text = f"solid t\nfacet normal 0 0 1\nouter loop\n{body}endloop\nendfacet\nendsolid t\n"
        yield case(f"stl-ascii-{k}", "mesh", text, OK, *UNREADABLE)
    yield case("stl-ascii-no-end", "mesh", "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n", *UNREADABLE)




def _deep_bvh(depth: int) -> str:
    opening = "".join(f"JOINT J{i}\n{{\nOFFSET 0 1 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n" for i in range(depth))
    return ("HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n" + opening + "}\n" * (depth + 1)
            + f"MOTION\nFrames: 1\nFrame Time: 0.03\n{' '.join(['0'] * 3 * (depth + 1))}\n")


def bvh_cases() -> Iterator[Case]:
    yield case("bvh-valid", "motion", BVH_OK, OK)
    bad = ("invalid_bvh", "too_many_frames", "too_many_joints", "file_too_large")
    edits = [("Frames: 2", "Frames: 3"), ("Frames: 2", "Frames: -2"), ("Frames: 2", "Frames: 0"), ("Frames: 2", "Frames: 1e12"),
             ("Frames: 2", "Frames: x"), ("Frame Time: 0.033333", "Frame Time: 0"), ("Frame Time: 0.033333", "Frame Time: nan"),
             ("Frame Time: 0.033333", "Frame Time: -1"), ("CHANNELS 3", "CHANNELS 7"), ("CHANNELS 3", "CHANNELS -1"),
             ("Zrotation Xrotation Yrotation\n    End", "Zrotation Xrotation Wrotation\n    End"),
             ("Zrotation Xrotation Yrotation\n    End", "Zrotation Zrotation Yrotation\n    End"),
             ("JOINT Spine", "JOINT Hips"), ("JOINT Spine", "JOINT"), ("OFFSET 0 10 0\n    CHANNELS", "OFFSET 0 nan 0\n    CHANNELS"),
             ("OFFSET 0 10 0\n    CHANNELS", "OFFSET 0 10\n    CHANNELS"), ("MOTION\n", ""), ("HIERARCHY\nROOT", "HIERARCHY\nJOINT"),
             ("1 90 0 10 20 30 40 50 60", "1 90 0 10 20 30 40 50"), ("1 90 0 10 20 30 40 50 60", "1 90 0 10 20 30 40 50 x"),
             ("1 90 0 10 20 30 40 50 60", "1 90 0 10 20 30 40 50 inf"), ("1 90 0 10 20 30 40 50 60", "1 90 0 10 20 30 40 50 60 0 0"),
             ("      OFFSET 0 10 0\n    }", "      OFFSET 0 10 0\n      CHANNELS 1 Xrotation\n    }"), ("}\nMOTION", "MOTION"),
             ("{\n  OFFSET 0 0 0", "  OFFSET 0 0 0"), ("End Site", "End Sight")]
    for k, (old, new) in enumerate(edits):
        assert old in BVH_OK, old
        yield case(f"bvh-edit-{k}", "motion", BVH_OK.replace(old, new, 1), *bad)
    yield case("bvh-not-utf8", "motion", BVH_OK.encode() + b"\xff\xfe\xfa", *bad)
    yield case("bvh-depth-200", "motion", _deep_bvh(200), *bad)
    yield case("bvh-depth-100", "motion", _deep_bvh(100), OK)
    yield case("bvh-joints-600", "motion", _wide_bvh(600), *bad)
    yield case("bvh-frames-200001", "motion", BVH_OK.replace("Frames: 2", "Frames: 200001"), *bad)
    yield case("bvh-as-mesh", "mesh", BVH_OK, "wrong_kind")


def _wide_bvh(joints: int) -> str:
    children = "".join(f"JOINT J{i}\n{{\nOFFSET 0 1 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n}}\n" for i in range(joints))
    return ("HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n" + children + "}\n"
            + f"MOTION\nFrames: 1\nFrame Time: 0.03\n{' '.join(['0'] * 3 * (joints + 1))}\n")


def text_cases() -> Iterator[Case]:
    yield from obj_cases()
    yield from ply_cases()
    yield from stl_cases()
    yield from bvh_cases()
