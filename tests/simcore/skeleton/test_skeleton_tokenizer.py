"""Skeleton tree tokenizer: vocabulary, round trips, sequence lengths, token savings."""

from __future__ import annotations

import numpy as np
import pytest

from simcore.errors import InvalidInput
from simcore.skeleton.tokenizer import Normalization, SkeletonTokenizer, strip_padding
from simcore.skeleton.types import JointKind, Skeleton
from simcore.skeleton.vocab import (
    BOS,
    BRANCH,
    CLASS_TOKENS,
    EOS,
    PAD,
    PART_BODY,
    PART_HAND,
    SPRING,
    VOCAB_SIZE,
    dequantize,
    quantize,
)
from tests.simcore.skeleton.skeleton_samples import MAX_TOKENIZED_JOINTS, dev_skeletons, random_tree

HALF_BIN = 1.0 / 256
IDENTITY = Normalization(np.zeros(3), 1.0)
TOK = SkeletonTokenizer()


def assert_round_trip(skeleton: Skeleton, norm: Normalization) -> np.ndarray:
    """Encode, decode, and check topology exactly, positions within half a bin, kinds and template names."""
    tokens = TOK.encode(skeleton, norm)
    decoded = TOK.decode(tokens, norm)
    plan = TOK.plan(skeleton, norm)
    expected = skeleton.reordered(plan.order)
    np.testing.assert_array_equal(decoded.parents, expected.parents)
    err = np.abs(norm.to_unit(decoded.positions) - norm.to_unit(expected.positions)).max()
    assert err <= HALF_BIN + 1e-9
    assert decoded.kinds == plan.kinds
    for got, want, kind in zip(decoded.names, expected.names, plan.kinds):
        if kind in (JointKind.BODY, JointKind.HAND):
            assert got == want
    # Canonical: the decoded skeleton encodes to the very same sequence.
    np.testing.assert_array_equal(TOK.encode(decoded, norm), tokens)
    return tokens


def test_vocabulary_matches_unirig_release() -> None:
    assert VOCAB_SIZE == 267
    assert (BRANCH, BOS, EOS, PAD, SPRING, PART_BODY, PART_HAND) == (256, 257, 258, 259, 260, 261, 262)
    assert CLASS_TOKENS == {"none": 263, "vroid": 264, "mixamo": 265, "articulation": 266}


def test_quantisation_floor_and_bin_centres() -> None:
    x = np.array([-1.0, -1.0 + 1e-9, -0.99, 0.0, 0.5, 1.0, 7.0, -7.0])
    np.testing.assert_array_equal(quantize(x), [0, 0, 1, 128, 192, 255, 255, 0])
    np.testing.assert_allclose(dequantize(np.array([0, 128, 255])), [-1 + 1 / 256, 1 / 256, 1 - 1 / 256])


def test_axis_mapping_is_a_rotation_from_y_up_to_z_up() -> None:
    ours = np.array([[1.0, 2.0, 3.0]])
    np.testing.assert_allclose(TOK.model_frame(ours), [[1.0, -3.0, 2.0]])
    np.testing.assert_allclose(TOK.from_model_frame(TOK.model_frame(ours)), ours)


def test_chain_costs_three_tokens_per_joint_and_branches_seven() -> None:
    # Root at the bottom, two children: the lower child (in model z = our y) is visited first.
    skel = Skeleton(np.array([[0, 0, 0], [0, 0.5, 0], [0.2, -0.5, 0], [0.2, -0.8, 0]]), np.array([-1, 0, 0, 2]),
                    ["r", "up", "down", "foot"])
    tokens = TOK.encode(skel, IDENTITY)
    b = lambda p: quantize(TOK.model_frame(np.asarray([p], float))[0]).tolist()  # noqa: E731
    expected = [BOS, CLASS_TOKENS["none"], *b([0, 0, 0]), *b([0.2, -0.5, 0]), *b([0.2, -0.8, 0]),
                BRANCH, *b([0, 0, 0]), *b([0, 0.5, 0]), EOS]
    assert tokens.tolist() == expected


def test_random_trees_round_trip_with_exact_lengths() -> None:
    rng = np.random.default_rng(7)
    for trial in range(1500):
        joints = int(rng.integers(1, 60))
        skel = random_tree(rng, joints)
        tokens = assert_round_trip(skel, IDENTITY)
        leaves = sum(1 for c in skel.children() if not c)
        # In DFS pre-order only the first child of each joint follows its parent: S = leaves - 1 branches.
        assert len(tokens) == 3 * joints + 4 * (leaves - 1) + 1 + 2, trial


def test_random_trees_with_templates_and_springs_round_trip() -> None:
    rng = np.random.default_rng(11)
    for trial in range(600):
        template = ("none", "body", "hand")[trial % 3]
        skel = random_tree(rng, int(rng.integers(1, 30)), template=template, spring_roots=int(rng.integers(0, 4)))
        tokens = assert_round_trip(skel, IDENTITY)
        plan = TOK.plan(skel, IDENTITY)
        assert plan.kinds == [skel.kinds[i] for i in plan.order]  # generated kinds are all expressible
        markers = int(np.isin(tokens, [PART_BODY, PART_HAND, SPRING]).sum())
        branches = int((tokens == BRANCH).sum())
        assert markers == {"none": 0, "body": 1, "hand": 2}[template] + len(
            [j for j in range(1, skel.num_joints) if skel.kinds[j] == JointKind.SPRING and skel.kinds[skel.parents[j]] != JointKind.SPRING])
        assert len(tokens) - 2 == 3 * skel.num_joints + markers + 4 * branches + 1 == TOK.optimized_length(plan)
        if template != "none":
            assert TOK.read_class(tokens) == "mixamo"
            assert tokens[2] == PART_BODY


def test_dev_skeletons_round_trip_and_report_saving(dev_assets) -> None:
    naive = optimised = 0
    names = []
    for name, skel, vertices in dev_skeletons(dev_assets, MAX_TOKENIZED_JOINTS):
        norm = Normalization.from_points(np.concatenate([vertices, skel.positions]))
        tokens = assert_round_trip(skel, norm)
        plan = TOK.plan(skel, norm)
        assert len(tokens) - 2 == TOK.optimized_length(plan)
        naive += TOK.naive_length(plan)
        optimised += TOK.optimized_length(plan)
        names.append(name)
    assert {"xbot", "fox", "rignet_17364_humanoid_a"} <= set(names)
    saving = 1 - optimised / naive
    print(f"dev skeletons: {len(names)}, naive {naive} tokens, optimised {optimised}, saving {saving:.1%}")
    assert 0.25 < saving < 0.5


def test_mixamo_rig_uses_body_and_hand_blocks(dev_assets) -> None:
    skel = dict((n, s) for n, s, _ in dev_skeletons(dev_assets))["xbot"]
    tokens = TOK.encode(skel, Normalization.from_points(skel.positions))
    assert tokens[2] == PART_BODY and tokens[3 + 66] == PART_HAND
    decoded = TOK.decode(tokens, Normalization.from_points(skel.positions))
    assert decoded.names[0] == "mixamorig:Hips" and decoded.kinds[0] == JointKind.BODY


def test_coincident_joints_resolve_to_the_ancestor() -> None:
    # Joint 1 sits exactly on its parent 0, which has a second child: the branch must go back to 0.
    skel = Skeleton(np.array([[0, 0, 0], [0, 0, 0], [0, -0.5, 0], [0.5, 0.5, 0]]), np.array([-1, 0, 1, 0]), ["a", "a_dup", "b", "c"])
    tokens = assert_round_trip(skel, IDENTITY)
    assert (tokens == BRANCH).sum() == 1


def test_decode_accepts_trailing_padding_and_rejects_bad_sequences() -> None:
    skel = Skeleton(np.array([[0, 0, 0], [0, 0.5, 0]]), np.array([-1, 0]), ["a", "b"])
    tokens = TOK.encode(skel, IDENTITY)
    padded = np.concatenate([tokens, [PAD, PAD]])
    assert TOK.decode(padded, IDENTITY).num_joints == 2
    np.testing.assert_array_equal(strip_padding(padded), tokens)
    with pytest.raises(InvalidInput) as err:
        TOK.decode(tokens[:-1], IDENTITY)
    assert err.value.code == "invalid_tokens"
    with pytest.raises(InvalidInput):
        TOK.decode(np.array([BOS, CLASS_TOKENS["none"], BRANCH, 1, 2, 3, 4, 5, 6, EOS]), IDENTITY)


def test_normalisation_from_mesh_bbox() -> None:
    norm = Normalization.from_points(np.array([[0.0, 0.0, 0.0], [2.0, 4.0, 1.0]]))
    np.testing.assert_allclose(norm.center, [1.0, 2.0, 0.5])
    assert norm.scale == 2.0
    np.testing.assert_allclose(norm.to_unit(np.array([[2.0, 4.0, 1.0]])), [[0.5, 1.0, 0.25]])
