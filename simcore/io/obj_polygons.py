"""Polygon-size cap for OBJ uploads: one n-gon is fan-triangulated into n - 2 triangles that, on a
non-planar polygon, each span the whole model (a 10,000-vertex face drove voxelisation to 5.7 GB)."""

from __future__ import annotations

import re

from simcore.errors import LimitExceeded

MAX_POLYGON_VERTICES = 256
# A face line with more than MAX_POLYGON_VERTICES references is at least 2 characters per reference long,
# so only lines that long need counting: the regex scan stays linear and in C.
_LONG_FACE = re.compile(rb"^[ \t]*f[ \t][^\n]{%d,}" % (2 * MAX_POLYGON_VERTICES - 1), re.MULTILINE)


def check_polygon_sizes(data: bytes) -> None:
    """Raise LimitExceeded(polygon_too_large) when an OBJ face has more than MAX_POLYGON_VERTICES vertices."""
    for match in _LONG_FACE.finditer(data):
        count = len(match.group().split()) - 1
        if count > MAX_POLYGON_VERTICES:
            line = data.count(b"\n", 0, match.start()) + 1
            raise LimitExceeded(f"line {line}: a face with {count} vertices; the limit is {MAX_POLYGON_VERTICES} "
                                "(triangulate large polygons before uploading)", code="polygon_too_large", field="mesh")
