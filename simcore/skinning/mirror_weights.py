"""Mirror-symmetric weights for mirror-symmetric characters.

Artists paint one side of a symmetric character and mirror it (Blender's Mirror Vertex Groups, Maya's Mirror
Skin Weights), so a pose and its mirror image deform alike. Every method here computes each side on its own: a
voxel grid that is not centred on the mid-plane, or the learned model seeing slightly different neighbourhoods,
leaves the two sides a little different, which shows as a crease on one side only, or as stretch across the
mid-plane on a coarse mesh whose two sides share an edge. When the mesh is its own mirror image
(`skeleton.symmetry.body_mirror`), joints are paired with their mirror twins (their positions mirror within
JOINT_MATCH of the size, and a twin's parent is the parent's twin, so each bone maps to its mirror bone) and
vertices with theirs (mirror images within VERTEX_MATCH, both ways: a mesh modelled with a mirror; at least
MIN_TWINNED of them, else nothing is mirrored); a vertex whose weights and whose twin's lie on twinned joints
only takes the mean of its row and its twin's with the columns swapped left for right.
The weights are mirrored last, after the surface smoothing (whose triangulation may differ a little between the
sides), and before each row keeps its largest influences.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from simcore.skeleton.mirror import MirrorPlane
from simcore.skeleton.symmetry import body_mirror, twins_at_scale
from simcore.skeleton.types import Skeleton

JOINT_MATCH = 0.02  # × size: a joint's mirror image lies this close to its twin
VERTEX_MATCH = 1e-3  # × size: a vertex's mirror image this close to another vertex makes them twins
# Share of the vertices that must have a twin: a mesh whose sides were triangulated apart has twins only here and
# there, and averaging those rows alone would make them differ from their neighbours' (a patchy stretch).
MIN_TWINNED = 0.5


@dataclass(frozen=True)
class WeightMirror:
    """How one mesh's weights mirror: the plane, each vertex's twin and each joint's (-1: none)."""

    plane: MirrorPlane
    vertex_twin: np.ndarray
    joint_twin: np.ndarray

    def apply(self, weights: np.ndarray) -> np.ndarray:
        """(V, J) copy of `weights` with each twinned vertex's row averaged with its twin's, mirrored, where both
        rows weight twinned joints only."""
        out = np.array(weights, dtype=np.float64, copy=True)
        unpaired = self.joint_twin < 0
        on_twinned = ~np.any(weights[:, unpaired] > 0.0, axis=1)  # every row when no joint is unpaired
        rows = np.flatnonzero((self.vertex_twin >= 0) & on_twinned)
        rows = rows[on_twinned[self.vertex_twin[rows]]]
        # twins swap in pairs, so column j of the mirrored row is the twin vertex's column twin[j] (an unpaired
        # joint's column is zero on these rows and maps to itself)
        columns = np.where(unpaired, np.arange(len(self.joint_twin)), self.joint_twin)
        out[rows] = 0.5 * (out[rows] + weights[np.ix_(self.vertex_twin[rows], columns)])
        return out

    def report(self) -> dict[str, object]:
        """report.json's `skinning.mirror`: the plane's axis, the share of vertices with a twin, the joints paired."""
        return {"axis": "xyz"[self.plane.axis], "vertices": round(float(np.mean(self.vertex_twin >= 0)), 4),
                "joints": int(np.count_nonzero(self.joint_twin >= 0))}


def weight_mirror(vertices: np.ndarray, skeleton: Skeleton) -> WeightMirror | None:
    """The mirror of a symmetric character (see the module docstring), or None when the mesh does not mirror or
    no vertex or no joint has a twin."""
    v = np.asarray(vertices, dtype=np.float64)
    plane = body_mirror(v)
    if plane is None:
        return None
    size = float(np.ptp(v, axis=0).max())
    pos = skeleton.positions
    twin = twins_at_scale(pos, skeleton.parents, size, plane, skeleton.names).twin
    paired = twin >= 0
    twin[paired & (np.linalg.norm(plane.reflect(pos) - pos[np.maximum(twin, 0)], axis=1) > JOINT_MATCH * size)] = -1
    twin = _bone_twins(twin, skeleton)
    distance, nearest = cKDTree(v).query(plane.reflect(v))
    mutual = (distance <= VERTEX_MATCH * size) & (nearest[nearest] == np.arange(len(v)))
    if mutual.mean() < MIN_TWINNED or not np.any(twin >= 0):
        return None
    return WeightMirror(plane, np.where(mutual, nearest, -1), twin)


def _bone_twins(twin: np.ndarray, skeleton: Skeleton) -> np.ndarray:
    """`twin` (J,) made a mirror of the tree: a joint keeps its twin only when the twin's parent is its parent's
    twin (each bone's weights go to the mirror bone). Joints at one place (a root copied once per limb, as
    RigNet's rigs do) are each their own mirror image by position; the one whose children's twins hang from another
    of them is first re-paired with that one."""
    twin = twin.copy()
    parents, children = skeleton.parents, skeleton.children()
    for j in range(skeleton.num_joints):
        hosts = {int(parents[twin[c]]) for c in children[j] if twin[c] >= 0}
        if len(hosts) == 1 and (host := hosts.pop()) >= 0 and twin[j] == j and twin[host] == host and host != j:
            twin[j], twin[host] = host, j
    while True:  # a joint whose parent has no twin, or the wrong one, loses its own (and so on down the tree)
        own = twin >= 0
        twin_up = np.where(parents >= 0, twin[np.maximum(parents, 0)], -1)  # the parent's twin (-1: root or none)
        good = own & (twin[np.maximum(twin, 0)] == np.arange(len(twin))) & (parents[np.maximum(twin, 0)] == twin_up)
        good &= (parents < 0) | (twin_up >= 0)
        bad = own & ~good
        if not bad.any():
            return twin
        twin[bad] = -1
        twin[np.flatnonzero(own & (twin >= 0) & bad[np.maximum(twin, 0)])] = -1
