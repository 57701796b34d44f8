"""OBJ faces over the polygon cap are refused by a linear scan; faces at the cap are read."""

from __future__ import annotations

import time

import pytest

from simcore.errors import LimitExceeded
from simcore.io.obj_polygons import MAX_POLYGON_VERTICES, check_polygon_sizes


def face(n: int) -> bytes:
    return b"f " + b" ".join(str(i + 1).encode() for i in range(n)) + b"\n"


def test_a_10000_vertex_face_is_refused_with_its_line():
    with pytest.raises(LimitExceeded) as err:
        check_polygon_sizes(b"v 0 0 0\n" * 3 + face(10_000))
    assert err.value.code == "polygon_too_large" and "line 4" in str(err.value)


def test_a_face_at_the_cap_and_slash_references_pass():
    check_polygon_sizes(face(MAX_POLYGON_VERTICES) + b"f 1/1/1 2/2/2 3/3/3\n")


def test_the_scan_is_fast_on_a_big_file():
    data = b"f 1 2 3\n" * 2_000_000  # 16 MB of ordinary faces
    started = time.perf_counter()
    check_polygon_sizes(data)
    assert time.perf_counter() - started < 1.0
