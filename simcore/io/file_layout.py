"""A kept studio rig written back in its upload's layout: skin joints in the file's order, the file's roots.

Our skeleton is one tree with parents first (Skeleton.file_order / file_parents remember the upload's skin
order and hierarchy). The glTF writer lays joints, weights and animation out in the file's order and under the
file's parents, so a re-skinned rig lists the same joints in the same order as the upload did. The USD writer keeps
our parents-first order (UsdSkel wants it) and the file's roots.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
from scipy.spatial.transform import Rotation

from simcore.io.joint_tracks import joint_tracks
from simcore.skeleton.kinematics import compose, global_transforms
from simcore.skeleton.types import Skeleton

if TYPE_CHECKING:
    from simcore.motion.types import JointAnimation


def file_skeleton(skeleton: Skeleton) -> tuple[Skeleton, np.ndarray]:
    """(the joints in the upload's order under the upload's parents (a forest, any order), order (J,) int64:
    which of `skeleton`'s joints is written at each position). Identity for a skeleton without a file layout."""
    if skeleton.file_order is None or skeleton.file_parents is None:
        return skeleton, np.arange(skeleton.num_joints)
    order = np.argsort(skeleton.file_order)
    written = skeleton.reordered(order)
    assert written.file_parents is not None  # reordered() keeps the file layout checked above
    return replace(written, parents=written.file_parents), order


def file_forest(skeleton: Skeleton) -> Skeleton:
    """The joints in our parents-first order under the upload's parents (its extra roots kept as roots).

    For writers whose format wants parents before children (UsdSkel): our order is parents-first for the joined
    tree, so it stays so once the joining edges are dropped. Identity without a file layout."""
    if skeleton.file_parents is None:
        return skeleton
    return replace(skeleton, parents=skeleton.file_parents.copy())


def file_weights(weights: sp.spmatrix, order: np.ndarray) -> sp.csr_matrix:
    """(V, J) weights with columns in the written order."""
    return sp.csr_matrix(weights)[:, order]


def file_animation(skeleton: Skeleton, written: Skeleton, animation: JointAnimation) -> JointAnimation:
    """`animation` (locals under `skeleton`'s parents) as locals under `written`'s parents. Joints whose parent is
    the same keep their tracks as they are; a re-parented joint (an upload's extra root) gets its world track
    expressed in its file parent's frame (the world for a root)."""
    slot = {name: j for j, name in enumerate(skeleton.names)}
    moved = [j for j, name in enumerate(written.names)
             if _parent_name(written, j) != _parent_name(skeleton, slot[name])]
    if not moved:
        return animation
    tracks = joint_tracks(skeleton, animation)
    world = global_transforms(skeleton, compose(tracks.rotations, tracks.translations))  # (T, J, 4, 4)
    names = list(animation.joint_names)
    rotations = list(np.moveaxis(animation.rotations, 1, 0))  # per joint: (T, 4)
    translations = list(np.moveaxis(animation.translations, 1, 0))  # per joint: (T, 3)
    for j in moved:
        own = world[:, slot[written.names[j]]]
        p = written.parents[j]
        local = own if p < 0 else np.linalg.inv(world[:, slot[written.names[p]]]) @ own
        quats = Rotation.from_matrix(local[:, :3, :3]).as_quat()
        if written.names[j] in names:
            k = names.index(written.names[j])
            rotations[k], translations[k] = quats, local[:, :3, 3]
        else:
            names.append(written.names[j])
            rotations.append(quats)
            translations.append(local[:, :3, 3])
    return replace(animation, joint_names=names, rotations=np.stack(rotations, axis=1),
                   translations=np.stack(translations, axis=1))


def _parent_name(skeleton: Skeleton, joint: int) -> str | None:
    """Name of `joint`'s parent (None for a root): parents compared by name across the two layouts."""
    p = int(skeleton.parents[joint])
    return None if p < 0 else skeleton.names[p]
