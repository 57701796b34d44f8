"""Helper joints (JointKind.HELPER: a kept rig's pole targets and end markers) own no bone and get no weight from
any method, while the bones their parents make to them stay."""

from __future__ import annotations

import numpy as np
import pytest

from simcore.errors import InvalidInput
from simcore.geometry.capsule_creatures import quadruped
from simcore.skeleton.types import JointKind, Skeleton
from simcore.skinning.bones import joint_segments
from simcore.skinning.predict import compute_weights


def _with_target(offset: float = 0.05) -> tuple[np.ndarray, np.ndarray, Skeleton, int]:
    """The capsule quadruped plus a pole target under the root, `offset` in front of its first foot (where it would
    pull weight)."""
    vertices, faces, skeleton = quadruped()
    foot = int(np.argmin(skeleton.positions[:, 1]))
    rig = Skeleton(np.vstack([skeleton.positions, skeleton.positions[foot] + [0.0, 0.0, offset]]),
                   np.append(skeleton.parents, 0), [*skeleton.names, "Pole"])
    return vertices, faces, rig, rig.num_joints - 1


def _helper(rig: Skeleton, pole: int) -> Skeleton:
    helper = rig.with_helpers(np.arange(rig.num_joints) == pole)
    assert helper.kinds[pole] == JointKind.HELPER and JointKind.HELPER not in helper.kinds[:pole]
    return helper


def test_a_helper_owns_no_segment_but_its_parents_bone_to_it_remains():
    _, _, rig, pole = _with_target()
    plain, helper = joint_segments(rig), joint_segments(_helper(rig, pole))
    assert pole in plain.owner and pole not in helper.owner
    assert len(helper.owner) == len(plain.owner) - 1  # only the pole's own leaf segment went
    assert np.any((helper.owner == 0) & np.all(np.isclose(helper.tails, rig.positions[pole]), axis=1))


def test_no_bone_leads_to_a_stale_helper():
    """A helper at another joint's bind position (an exporter's stale transform) gets no bone from its parent."""
    _, _, rig, pole = _with_target(offset=0.0)  # exactly on the foot joint
    plain, helper = joint_segments(rig), joint_segments(_helper(rig, pole))
    assert len(helper.owner) == len(plain.owner) - 2  # its own leaf segment and the root's bone to it
    assert not np.any(np.all(np.isclose(helper.tails, rig.positions[pole]), axis=1) & (helper.owner == 0))


@pytest.mark.parametrize("method", ["learned", "geodesic", "heat"])
def test_every_method_leaves_excluded_joints_empty(method):
    vertices, faces, rig, pole = _with_target()
    out = np.zeros(rig.num_joints, bool)
    out[pole] = True
    weights = compute_weights(vertices, faces, rig, method=method, exclude=out).weights
    assert weights[:, pole].sum() == 0.0
    assert np.all(np.isfinite(weights.data))
    np.testing.assert_allclose(np.asarray(weights.sum(axis=1)).ravel(), 1.0, atol=1e-5)
    assert compute_weights(vertices, faces, rig, method="geodesic").weights[:, pole].sum() > 1.0  # left in, it pulls weight


def test_the_root_cannot_be_a_helper():
    vertices, faces, rig, _ = _with_target()
    with pytest.raises(InvalidInput):
        compute_weights(vertices, faces, rig, method="geodesic", exclude=np.arange(rig.num_joints) == 0)
