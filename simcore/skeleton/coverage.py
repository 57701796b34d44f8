"""Parts of a mesh that no bone comes near: a second character beside the first, or a prop set far away.

The humanoid fit rigs one body; a part far from every bone would follow the nearest one rigidly, which the
skeleton stage reports instead of leaving the user to find it in the animation.
"""

from __future__ import annotations

import numpy as np

from simcore.geometry.parts import SurfacePart
from simcore.skeleton.types import Skeleton
from simcore.skinning.bones import closest_on_segments, joint_segments

FAR = 0.4  # × the model's size: a part whose every point is farther than this from every bone is unreached
# (0.25 flagged the top of robot_expressive's big head, 0.32 from its head bone, which the artist bound rigidly)
MIN_AREA = 0.01  # share of the area: smaller parts (an eye, a button) are not reported
SAMPLES = 2000  # points per part measured


def unreached_parts(parts: list[SurfacePart], skeleton: Skeleton) -> list[SurfacePart]:
    """The parts (holding at least MIN_AREA of the area) farther than FAR × the model's size from every bone.

    parts: the mesh's connected parts (surface_parts); skeleton: in the same frame.
    """
    if not parts:
        return []
    points = np.concatenate([p.points for p in parts])
    size = float(np.ptp(points, axis=0).max())
    total = sum(p.area for p in parts)
    seg = joint_segments(skeleton)
    out = []
    for part in parts:
        if part.area < MIN_AREA * total:
            continue
        sample = part.points[:: max(1, len(part.points) // SAMPLES)]  # a connected part: its spacing ≪ FAR
        nearest = float(closest_on_segments(sample, seg.heads, seg.tails)[0].min())
        if nearest > FAR * size:
            out.append(part)
    return out
