"""Parts of a mesh that no bone comes near: a second character beside the first, or a prop set far away.

The humanoid fit rigs one body; a part far from every bone would follow the nearest one rigidly, which the
skeleton stage reports instead of leaving the user to find it in the animation.
"""

from __future__ import annotations

import numpy as np

from simcore.geometry.parts import SurfacePart
from simcore.geometry.voxelize import surface_samples
from simcore.skeleton.types import Skeleton
from simcore.skinning.bones import closest_on_segments, joint_segments

FAR = 0.4  # × the model's size: a part whose surface is farther than this from every bone is unreached
# (well beyond a limb's or head's own reach from its bone: a big, rigidly bound head is still reached, a separate
# figure or a prop set apart is not)
MIN_AREA = 0.01  # share of the area: smaller parts (an eye, a button) are not reported
SPACING = 0.05  # × the model's size: how densely a part's surface is measured (big triangles are not just corners)
SAMPLES = 4000  # at most this many of those points per part


def unreached_parts(vertices: np.ndarray, faces: np.ndarray, parts: list[SurfacePart], skeleton: Skeleton) -> list[SurfacePart]:
    """The parts (holding at least MIN_AREA of the area) farther than FAR × the model's size from every bone.

    vertices (V, 3), faces (F, 3): the mesh; parts: its connected parts (surface_parts), or some of them;
    skeleton: in the same frame. A part with a joint inside its bounding box (a blob around its one joint, a
    sheet with its chain in it) is reached.
    """
    if not parts:
        return []
    size = float(np.ptp(np.concatenate([p.points for p in parts]), axis=0).max())
    total = sum(p.area for p in parts)
    seg = joint_segments(skeleton)
    out = []
    for part in parts:
        if part.area < MIN_AREA * total:
            continue
        lo, hi = part.points.min(axis=0) - 1e-6 * size, part.points.max(axis=0) + 1e-6 * size
        if np.any(np.all((skeleton.positions >= lo) & (skeleton.positions <= hi), axis=1)):
            continue
        points = surface_samples(vertices, faces[part.faces], SPACING * size)
        points = points[:: max(1, len(points) // SAMPLES)]
        if float(closest_on_segments(points, seg.heads, seg.tails)[0].min()) > FAR * size:
            out.append(part)
    return out
