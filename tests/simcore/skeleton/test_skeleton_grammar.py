"""Grammar state machine: every sequence it allows decodes to a valid tree; true sequences are allowed."""

from __future__ import annotations

import numpy as np
import pytest

from simcore.errors import InvalidInput
from simcore.skeleton.grammar import SkeletonGrammar
from simcore.skeleton.tokenizer import Normalization, SkeletonTokenizer
from simcore.skeleton.vocab import BOS, BRANCH, CLASS_TOKENS, EOS, NUM_BINS, PAD, PART_BODY, PART_HAND, SPRING
from tests.simcore.skeleton.skeleton_samples import MAX_TOKENIZED_JOINTS, dev_skeletons, random_tree

IDENTITY = Normalization(np.zeros(3), 1.0)
SPECIALS = np.arange(NUM_BINS, 267)


def random_walk(grammar: SkeletonGrammar, rng: np.random.Generator, special_bias: float) -> list[int]:
    """Sample allowed tokens until <eos>; specials are chosen with probability `special_bias` when legal."""
    state = grammar.initial()
    tokens: list[int] = []
    while not state.complete:
        mask = grammar.allowed(state)
        assert mask.any(), f"dead end after {tokens}"
        specials = SPECIALS[mask[NUM_BINS:]]
        coords = mask[:NUM_BINS].any()
        if len(specials) and (not coords or rng.random() < special_bias):
            token = int(rng.choice(specials))
        else:
            token = int(rng.integers(0, NUM_BINS))
        tokens.append(token)
        state = grammar.advance(state, token)
    return tokens


def test_random_walks_decode_to_valid_trees_within_limits() -> None:
    rng = np.random.default_rng(3)
    tok = SkeletonTokenizer()
    seen = set()
    for walk in range(1500):
        max_length = int(rng.choice([6, 12, 40, 80, 200]))
        max_joints = None if walk % 2 else int(rng.integers(1, 60))
        grammar = SkeletonGrammar(max_length=max_length, max_joints=max_joints)
        tokens = random_walk(grammar, rng, special_bias=float(rng.choice([0.05, 0.3, 0.7])))
        assert len(tokens) <= max_length
        skel = tok.decode(np.asarray(tokens), IDENTITY)  # decode validates the tree
        skel.validate()
        assert max_joints is None or skel.num_joints <= max_joints
        seen.update(set(tokens) & {BRANCH, SPRING, PART_BODY, PART_HAND})
    assert seen == {BRANCH, SPRING, PART_BODY, PART_HAND}  # the walks exercised every construct


def test_true_sequences_of_dev_and_random_skeletons_are_allowed(dev_assets) -> None:
    grammar = SkeletonGrammar()
    tok = SkeletonTokenizer()
    sequences = []
    for _, skel, vertices in dev_skeletons(dev_assets, MAX_TOKENIZED_JOINTS):
        sequences.append(tok.encode(skel, Normalization.from_points(np.concatenate([vertices, skel.positions]))))
    rng = np.random.default_rng(5)
    for trial in range(300):
        skel = random_tree(rng, int(rng.integers(1, 25)), template=("none", "body", "hand")[trial % 3], spring_roots=2)
        sequences.append(tok.encode(skel, IDENTITY))
    for tokens in sequences:
        state = grammar.initial()
        for t in tokens:
            assert grammar.allowed(state)[t]
            state = grammar.advance(state, t)
        assert state.complete
        # A tight length cap still admits the sequence exactly.
        assert SkeletonGrammar(max_length=len(tokens)).run(tokens).complete


def test_illegal_constructs_are_masked() -> None:
    g = SkeletonGrammar()
    after_cls = g.mask([BOS, CLASS_TOKENS["mixamo"]])
    assert after_cls[:NUM_BINS].all() and after_cls[PART_BODY]
    assert not after_cls[[BRANCH, SPRING, EOS, PART_HAND, PAD, BOS]].any()
    one_joint = g.mask([BOS, CLASS_TOKENS["none"], 1, 2, 3])
    assert one_joint[[BRANCH, SPRING, EOS]].all() and not one_joint[[PART_BODY, PART_HAND]].any()
    after_spring = g.mask([BOS, CLASS_TOKENS["none"], 1, 2, 3, SPRING])
    assert after_spring[BRANCH] and after_spring[:NUM_BINS].all() and not after_spring[[EOS, SPRING]].any()
    body = [BOS, CLASS_TOKENS["mixamo"], PART_BODY] + [5] * 66
    assert g.mask(body)[PART_HAND] and not g.mask(body[:-1])[PART_HAND]
    assert not g.mask(body + [1, 2, 3])[PART_HAND]
    assert g.mask(body + [EOS]).tolist() == [t == PAD for t in range(267)]
    with pytest.raises(InvalidInput) as err:
        g.run([BOS, CLASS_TOKENS["none"], EOS])
    assert err.value.code == "invalid_tokens"


def test_length_and_joint_caps_force_closure() -> None:
    g = SkeletonGrammar(max_length=6)
    assert not g.mask([BOS, CLASS_TOKENS["none"]])[PART_BODY]
    assert g.mask([BOS, CLASS_TOKENS["none"], 1, 2, 3]).tolist() == [t == EOS for t in range(267)]
    g = SkeletonGrammar(max_joints=2)
    two = g.mask([BOS, CLASS_TOKENS["none"], 1, 2, 3, 4, 5, 6])
    assert two[EOS] and not two[:NUM_BINS].any() and not two[[BRANCH, SPRING]].any()
    assert not SkeletonGrammar(max_joints=21).mask([BOS, CLASS_TOKENS["mixamo"]])[PART_BODY]
    with pytest.raises(InvalidInput):
        SkeletonGrammar(max_length=5)
