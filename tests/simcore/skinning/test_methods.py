"""Skinning methods on a generated bent tube creature with a 3-joint chain."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from simcore.errors import InvalidInput
from simcore.metrics.skinning import weight_stats
from simcore.skeleton.types import Skeleton
from simcore.skinning import predict
from simcore.skinning.geodesic import geodesic_distances
from simcore.skinning.learned import LearnedSkinning
from simcore.skinning.predict import Method, compute_weights
from tests.meshes import joined


@pytest.fixture(scope="module")
def bent_tube() -> tuple[np.ndarray, np.ndarray, Skeleton]:
    """A 3 m capsule (radius 0.3) along +Y, upper half bent 60° towards +X about the middle joint."""
    mesh = trimesh.creation.capsule(height=3.0, radius=0.3, count=[16, 16])
    v, f = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, 0.12)
    v = v[:, [0, 2, 1]] * [1, 1, -1]  # capsule axis Z → Y (a proper rotation: det = +1)
    f = f[:, [0, 2, 1]]
    bend = np.deg2rad(60.0)
    upper = v[:, 1] > 0.0
    rot = np.array([[np.cos(bend), np.sin(bend), 0], [-np.sin(bend), np.cos(bend), 0], [0, 0, 1]])
    v[upper] = v[upper] @ rot.T
    joints = np.array([[0.0, -1.5, 0.0], [0.0, 0.0, 0.0], rot @ [0.0, 1.5, 0.0]])
    return v, f, Skeleton(joints, np.array([-1, 0, 1]), ["root", "mid", "tip"])


def _dominant_joint_near_bones(v: np.ndarray, skeleton: Skeleton, weights: np.ndarray) -> None:
    """Vertices around the middle of bone root→mid belong to root; around mid→tip's bone, to mid."""
    lower = np.linalg.norm(v - [0.0, -0.75, 0.0], axis=1) < 0.45
    upper = np.linalg.norm(v - skeleton.positions[2] * 0.5, axis=1) < 0.45
    assert lower.sum() > 20 and upper.sum() > 20
    assert np.mean(weights[lower].argmax(axis=1) == 0) > 0.95
    assert np.mean(weights[upper].argmax(axis=1) == 1) > 0.95
    assert weights[lower, 0].mean() > 0.8 and weights[upper, 1].mean() > 0.8


@pytest.mark.parametrize("method", ["learned", "geodesic", "heat", "auto"])
def test_methods_give_bone_dominated_normalised_sparse_weights(bent_tube, method: Method) -> None:
    v, f, skeleton = bent_tube
    # The tube's root is a body joint that bends it (its bone is the lower half), as on a predicted skeleton; read as an
    # armature root, the learned model rightly hedges towards leaving it unweighted, as artists leave theirs.
    result = compute_weights(v, f, skeleton, method=method, max_influences=2, smooth_iterations=2, root_deforms=True)
    w = result.weights.toarray()
    assert result.weights.shape == (len(v), 3) and result.weights.dtype == np.float32
    stats = weight_stats(result.weights)
    assert stats["unweighted_vertices"] == 0
    assert stats["max_influences"] <= 2
    np.testing.assert_allclose(w.sum(axis=1), 1.0, atol=1e-5)
    _dominant_joint_near_bones(v, skeleton, w)
    expected = {"learned"} if method == "auto" else {method}  # the shipped model loads: auto takes it
    assert set(result.scores) == expected and result.method in expected
    assert all(np.isfinite(s["score"]) for s in result.scores.values())
    assert ("corpus val L1" in result.reason and result.reason.startswith("learned model")) == (method == "auto")
    assert (f"to the share {LearnedSkinning().prior_share:g}" in result.reason) == (method == "auto")  # what it ran


def test_auto_falls_back_to_the_hand_written_methods_without_the_model(bent_tube, tmp_path) -> None:
    v, f, skeleton = bent_tube
    result = compute_weights(v, f, skeleton, method="auto", learned=LearnedSkinning(tmp_path / "nowhere.safetensors"))
    assert set(result.scores) == {"geodesic", "heat"} and result.method in {"geodesic", "heat"}
    assert "nowhere.safetensors" in result.reason


def test_duplicate_vertices_get_identical_weights(bent_tube) -> None:
    """Flat-shaded copy (every corner its own vertex): coincident vertices must not get different weights."""
    v, f, skeleton = bent_tube
    flat_v, flat_f = v[f.reshape(-1)], np.arange(f.size).reshape(-1, 3)
    result = compute_weights(flat_v, flat_f, skeleton, method="heat")
    w = result.weights.toarray()
    corner_of = f.reshape(-1)  # original vertex behind each flat corner
    first_corner = np.full(len(v), -1)
    first_corner[corner_of[::-1]] = np.arange(len(corner_of))[::-1]
    np.testing.assert_allclose(w, w[first_corner[corner_of]], atol=1e-6)
    assert weight_stats(result.weights)["unweighted_vertices"] == 0
    _dominant_joint_near_bones(flat_v, skeleton, w)


def _u_tube() -> trimesh.Trimesh:
    """Two upright arms (x = ±0.6, radius 0.2, z in ±1.2) joined by a base at z = -1: a 0.8 m gap between them."""
    arms = []
    for x in (-0.6, 0.6):
        arm = trimesh.creation.capsule(height=2.0, radius=0.2, count=[12, 12])
        arm.apply_translation([x, 0.0, 0.0])
        arms.append(arm)
    base = trimesh.creation.capsule(height=1.2, radius=0.2, count=[12, 12])
    base.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    base.apply_translation([0.0, 0.0, -1.0])
    return joined(arms + [base])


def test_geodesic_distance_goes_around_not_across_a_gap() -> None:
    """A U-shaped tube: the straight line between the arms crosses empty space, the geodesic must not."""
    mesh = _u_tube()
    skeleton = Skeleton(np.array([[-0.6, 0.0, -0.9], [-0.6, 0.0, 0.9]]), np.array([-1, 0]), ["left", "left_tip"])
    d = geodesic_distances(mesh.vertices, mesh.faces, skeleton, leaf_extension=0.0)
    right_top = np.flatnonzero((mesh.vertices[:, 0] > 0.7) & (mesh.vertices[:, 2] > 0.8))
    assert len(right_top) > 0
    # Straight line from the right arm's top to the left bone ≈ 1.2 m; through the U it is ≥ 1.8 m.
    assert d[right_top, 0].min() > 1.8


def test_heat_skips_a_nearer_bone_hidden_across_a_gap() -> None:
    """The right arm's bone stops low, so the left arm's bone is nearer in a straight line to the right arm's top;
    that line crosses the gap, so bone heat must heat the top from the right bone (visible along the arm)."""
    mesh = _u_tube()
    joints = np.array([[0.0, 0.0, -1.0], [-0.6, 0.0, -0.9], [-0.6, 0.0, 0.9], [0.6, 0.0, -0.9], [0.6, 0.0, -0.5]])
    skeleton = Skeleton(joints, np.array([-1, 0, 1, 0, 3]), ["root", "left", "left_tip", "right", "right_tip"])
    weights = compute_weights(mesh.vertices, mesh.faces, skeleton, method="heat", smooth_iterations=0).weights.toarray()
    top = np.flatnonzero((mesh.vertices[:, 0] > 0.3) & (mesh.vertices[:, 2] > 0.9))
    assert len(top) > 10
    left_side = weights[top][:, [1, 2]].sum(axis=1)  # the left arm's joints
    assert left_side.max() < 0.05, left_side.max()


def test_rejects_bad_input(bent_tube) -> None:
    v, f, skeleton = bent_tube
    with pytest.raises(InvalidInput) as err:
        compute_weights(v, f + len(v), skeleton)
    assert err.value.code == "invalid_mesh"
    with pytest.raises(InvalidInput) as err:
        compute_weights(v, f, skeleton, method="magic")  # type: ignore[arg-type]
    assert err.value.field == "skinning"


def test_refuses_more_weights_than_memory_allows(bent_tube, monkeypatch) -> None:
    """Dense (vertices × joints) arrays would be OOM-killed (three lost attempts, no reason): refuse up front."""
    from simcore.errors import LimitExceeded

    v, f, skeleton = bent_tube
    monkeypatch.setattr(predict, "MAX_ENTRIES", len(v) * skeleton.num_joints - 1)
    with pytest.raises(LimitExceeded) as err:
        compute_weights(v, f, skeleton)
    assert err.value.code == "too_large_to_skin" and err.value.field == "mesh"
    assert "max_joints" in str(err.value)


def test_auto_reports_progress_while_the_methods_run(bent_tube, monkeypatch) -> None:

    monkeypatch.setattr(predict, "PROGRESS_POLL_S", 0.0)  # hear every checkpoint
    v, f, skeleton = bent_tube
    seen: list[float] = []
    compute_weights(v, f, skeleton, method="auto", progress=seen.append)
    assert seen == sorted(seen) and seen[-1] == 1.0
    assert len(set(seen)) > 3  # checkpoints inside the methods, not one step per finished method


def test_cancel_stops_both_methods(bent_tube, monkeypatch) -> None:
    from simcore.errors import Canceled
    from simcore.skinning import geodesic

    monkeypatch.setattr(predict, "PROGRESS_POLL_S", 0.0)
    finished: list[bool] = []
    falloff = geodesic.falloff_weights
    def counted_falloff(*a, **k):
        finished.append(True)
        return falloff(*a, **k)

    monkeypatch.setattr(geodesic, "falloff_weights", counted_falloff)

    def cancel(fraction: float) -> None:
        raise Canceled("the job was canceled")

    v, f, skeleton = bent_tube
    with pytest.raises(Canceled):
        compute_weights(v, f, skeleton, method="auto", progress=cancel)
    assert not finished  # the geodesic method stopped at a checkpoint instead of running to the end


@pytest.mark.parametrize("method", ["geodesic", "heat"])
def test_floating_part_and_single_joint_still_get_weights(bent_tube, method: Method) -> None:
    """A detached sphere far from every bone (an accessory) is weighted too; a one-joint skeleton works."""
    v, f, skeleton = bent_tube
    ball = trimesh.creation.icosphere(subdivisions=2, radius=0.2)
    ball.apply_translation([3.0, 0.0, 0.0])
    verts = np.vstack([v, ball.vertices])
    faces = np.vstack([f, ball.faces + len(v)])
    result = compute_weights(verts, faces, skeleton, method=method, max_influences=8)
    assert weight_stats(result.weights)["unweighted_vertices"] == 0
    np.testing.assert_allclose(np.asarray(result.weights.sum(axis=1)).ravel(), 1.0, atol=1e-5)
    lone = Skeleton(np.zeros((1, 3)), np.array([-1]), ["root"])
    single = compute_weights(v, f, lone, method=method).weights.toarray()
    np.testing.assert_allclose(single, 1.0)


def test_armature_root_sits_below_the_root_and_adopts_it(bent_tube) -> None:
    from simcore.skinning.learned import ARMATURE_ROOT, with_armature_root

    v, _, skeleton = bent_tube
    grown = with_armature_root(v, skeleton)
    assert grown.names == [ARMATURE_ROOT, "root", "mid", "tip"]
    assert grown.parents.tolist() == [-1, 0, 1, 2]
    assert np.isclose(grown.positions[0, 1], v[:, 1].min())
    assert np.allclose(grown.positions[1:], skeleton.positions)


def test_a_deforming_root_keeps_its_share_under_the_learned_model(bent_tube) -> None:
    """The model's own weights give a deforming root more of the lower tube; the geodesic prior, which weights
    every root alike, leaves it still gaining."""
    v, f, skeleton = bent_tube
    for share, gain in ((0.0, 1.05), (LearnedSkinning().prior_share, 1.0)):
        plain = compute_weights(v, f, skeleton, method="learned", learned=LearnedSkinning(prior_share=share)).weights.toarray()
        body = compute_weights(v, f, skeleton, method="learned", root_deforms=True,
                               learned=LearnedSkinning(prior_share=share)).weights.toarray()
        assert body.shape == plain.shape
        np.testing.assert_allclose(body.sum(axis=1), 1.0, atol=1e-5)
        _dominant_joint_near_bones(v, skeleton, body)
        assert body[:, 0].sum() > gain * plain[:, 0].sum()  # the root bends the lower tube: it gains weight


def test_the_learned_model_averages_the_character_and_its_half_turn(bent_tube, monkeypatch: pytest.MonkeyPatch) -> None:
    """Two readings, the character as it is and turned half a turn about the up axis, averaged; one reading where
    every member reading it twice would cost too much time."""
    from simcore.skinning import learned
    from simcore.skinning.pair_features import skin_inputs, turned

    v, f, skeleton = bent_tube
    inputs = skin_inputs(v, f, skeleton)
    back = turned(inputs, np.pi)
    np.testing.assert_allclose(back.point[:, :3], inputs.point[:, :3] * [-1, 1, -1], atol=1e-6)
    np.testing.assert_allclose(back.bone[:, 3:6], inputs.bone[:, 3:6] * [-1, 1, -1], atol=1e-6)
    np.testing.assert_array_equal(back.pair, inputs.pair)
    both = learned.learned_weights(v, f, skeleton, learned=LearnedSkinning(prior_share=0.0))
    monkeypatch.setattr(learned, "TURNS", (0.0,))
    front = learned.learned_weights(v, f, skeleton, learned=LearnedSkinning(prior_share=0.0))
    monkeypatch.setattr(learned, "TURNS", (np.pi,))
    behind = learned.learned_weights(v, f, skeleton, learned=LearnedSkinning(prior_share=0.0))
    assert np.abs(front - behind).max() > 1e-3  # the turn changes what the model reads
    np.testing.assert_allclose(both, 0.5 * (front + behind), atol=1e-9)
    monkeypatch.setattr(learned, "TURNS", (0.0, np.pi))
    members = len(learned.load_model().members)  # every member, but not twice: one reading
    monkeypatch.setattr(learned, "PASS_PAIRS", inputs.candidates.size * members * 2 - 1)
    np.testing.assert_allclose(learned.learned_weights(v, f, skeleton, learned=LearnedSkinning(prior_share=0.0)), front, atol=1e-12)


def test_the_learned_weights_are_multiplied_by_the_geodesic_prior_to_its_share(bent_tube) -> None:
    """Each vertex's weights ∝ model^(1 − s) · prior^s over its candidate joints; s = 0 is the model alone, s = 1
    the geodesic prior the model reads."""
    from simcore.skinning import learned
    from simcore.skinning.pair_features import skin_inputs

    v, f, skeleton = bent_tube
    inputs = skin_inputs(v, f, skeleton)
    alone = learned.learned_weights(v, f, skeleton, learned=LearnedSkinning(prior_share=0.0))
    mixed = learned.learned_weights(v, f, skeleton, learned=LearnedSkinning(prior_share=0.3))
    np.testing.assert_allclose(mixed.sum(axis=1), 1.0, atol=1e-9)
    model = np.take_along_axis(alone, inputs.candidates, axis=1)
    prior = np.exp(inputs.prior.astype(np.float64))
    expected = np.maximum(model, 1e-12) ** 0.7 * prior ** 0.3
    np.testing.assert_allclose(np.take_along_axis(mixed, inputs.candidates, axis=1),
                               expected / expected.sum(axis=1, keepdims=True), atol=1e-6)
    only_prior = np.take_along_axis(learned.learned_weights(v, f, skeleton, learned=LearnedSkinning(prior_share=1.0)), inputs.candidates, axis=1)
    np.testing.assert_allclose(only_prior, prior / prior.sum(axis=1, keepdims=True), atol=1e-6)
    assert np.abs(mixed - alone).max() > 1e-3  # the prior moves the weights
