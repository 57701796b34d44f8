"""Ground planes under a model: flat, level parts (floors, base plates) that everything else stands on.

Downloaded characters often come with the floor or base plate they were shown on. Left in, such a plane makes
the skeleton a sheet or a second body (a humanoid is no longer found), and its corners follow whichever foot is
nearest. The pipeline builds the skeleton without it and binds it to the root joint, and report.json says so.
The mesh frame is +Y up (what ingest produces).
"""

from __future__ import annotations

import numpy as np

from simcore.geometry.parts import SurfacePart, flat_normal

FLATNESS = 0.1  # thinner than this × its length: a floor, or a base plate or disc (5 cm under 1 m is 0.05)
MAX_TILT_DEG = 10.0  # its normal is within this of +Y
SUNK = 0.02  # the rest may reach this share of its height below the plane (feet sunk into the floor)


def ground_faces(parts: list[SurfacePart], face_count: int) -> np.ndarray:
    """(F,) bool: the triangles of ground planes under the rest of the mesh (+Y up).

    parts: the mesh's connected parts (surface_parts) over its `face_count` triangles. A ground plane is a part
    that is flat and level, lies under every other part (but for SUNK), and has the rest's horizontal centre
    over it. A mesh that is nothing but flat parts has no ground.
    """
    normals = [flat_normal(p.points, FLATNESS) if len(p.points) >= 3 else None for p in parts]
    level = [p for p, n in zip(parts, normals) if n is not None and abs(n[1]) >= np.cos(np.deg2rad(MAX_TILT_DEG))]
    rest = [p for p in parts if all(p is not q for q in level)]
    out = np.zeros(face_count, bool)
    if not level or not rest:
        return out
    body = np.concatenate([p.points for p in rest])
    bottom, height = float(body[:, 1].min()), float(np.ptp(body[:, 1]))
    centre = body.mean(axis=0)
    for part in level:
        lo, hi = part.points.min(axis=0), part.points.max(axis=0)
        under = float(np.median(part.points[:, 1])) <= bottom + SUNK * height
        covers = lo[0] <= centre[0] <= hi[0] and lo[2] <= centre[2] <= hi[2]
        if under and covers and height > 0:
            out[part.faces] = True
    return out
