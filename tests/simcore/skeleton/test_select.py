"""`auto` as a selection: the quality score, the chosen candidate and its reason, the geometric rule switches."""

from __future__ import annotations

from dataclasses import fields

import numpy as np
import pytest

from simcore.geometry.capsule_creatures import quadruped
from simcore.skeleton.candidate_score import score_candidate, shape_context
from simcore.skeleton.candidates import Candidate
from simcore.skeleton.geometric import GeometricParams
from simcore.skeleton.geometric_rules import RULES, plain_params, without_rule
from simcore.skeleton.predict import predict_skeleton
from simcore.skeleton.select import MARGIN, select_candidate
from simcore.skeleton.types import JointKind, Skeleton


@pytest.fixture(scope="module")
def dog():
    vertices, faces, truth = quadruped()
    return vertices, faces, truth, shape_context(vertices, faces)


def _stick(truth: Skeleton) -> Skeleton:
    """A two-joint skeleton along the dog's trunk only: no legs, head or tail."""
    ends = truth.positions[[truth.names.index("pelvis"), truth.names.index("chest")]]
    return Skeleton(ends, np.array([-1, 0]), ["a", "b"], [JointKind.FREE] * 2)


def test_the_true_skeleton_outscores_a_trunk_stick(dog):
    _, _, truth, shape = dog
    good, bad = score_candidate(truth, shape), score_candidate(_stick(truth), shape)
    assert good.total > bad.total and good.medial_gap < bad.medial_gap  # no bone runs down the legs of a stick


def test_the_preferred_candidate_is_kept_within_the_margin_and_a_clearly_better_one_wins(dog):
    _, _, truth, shape = dog
    pool = [Candidate(_stick(truth), "stick"), Candidate(truth, "truth")]
    gap = score_candidate(truth, shape).total - score_candidate(_stick(truth), shape).total
    clear = select_candidate(pool, shape, margin=0.5 * gap)
    assert clear.chosen.method == "truth" and clear.reason.startswith("truth: the best score")
    assert "others stick" in clear.reason
    kept = select_candidate(pool, shape, margin=2.0 * gap)
    assert kept.chosen.method == "stick" and "preferred" in kept.reason
    report = clear.report(pool)
    assert report["chosen"] == "truth" and [c["method"] for c in report["candidates"]] == ["stick", "truth"]


def test_a_skeleton_with_joints_outside_and_stacked_scores_lower(dog):
    _, _, truth, shape = dog
    outside = Skeleton(truth.positions + np.array([0.0, 2.0, 0.0]), truth.parents, truth.names, truth.kinds)
    stacked = Skeleton(np.repeat(truth.positions[:1], truth.num_joints, axis=0), truth.parents, truth.names, truth.kinds)
    base = score_candidate(truth, shape)
    assert score_candidate(outside, shape).inside == 0.0 < base.inside
    assert score_candidate(stacked, shape).stacked == 1.0 > base.stacked
    assert max(score_candidate(outside, shape).total, score_candidate(stacked, shape).total) < base.total


def _with_fingers(truth: Skeleton) -> Skeleton:
    """The truth with a chain of three finger joints (JointKind.HAND), 2 mm apart, on each of its leaves."""
    leaves = [j for j in range(truth.num_joints) if j not in set(truth.parents.tolist())]
    positions, parents = list(truth.positions), list(truth.parents)
    names, kinds = list(truth.names), list(truth.kinds)
    for leaf in leaves:
        for k in range(3):
            positions.append(truth.positions[leaf] + np.array([0.002 * (k + 1), 0.0, 0.0]))
            parents.append(leaf if k == 0 else len(positions) - 2)
            names.append(f"finger{leaf}_{k}")
            kinds.append(JointKind.HAND)
    return Skeleton(np.array(positions), np.array(parents), names, kinds)


def test_auto_does_not_hold_finger_joints_against_a_candidate(dog):
    _, _, truth, shape = dog
    fingered = _with_fingers(truth)
    assert score_candidate(fingered, shape).stacked > 0.5  # finger bones are shorter than the score resolves
    pool = [Candidate(fingered, "humanoid"), Candidate(truth, "geometric")]
    selection = select_candidate(pool, shape, margin=1e-9)
    assert selection.chosen.method == "humanoid"  # scored as its body alone: the same score as the truth
    assert selection.scores[0].total == pytest.approx(selection.scores[1].total)


def test_auto_reports_every_candidate_and_why_one_won(dog):
    vertices, faces, _, _ = dog
    prediction = predict_skeleton(vertices, faces, method="auto")
    auto = prediction.report["auto"]
    assert prediction.method == auto["chosen"] and auto["reason"].startswith(auto["chosen"])
    assert [c["method"] for c in auto["candidates"]] == ["geometric"]  # no biped
    chosen = next(c for c in auto["candidates"] if c["method"] == prediction.method)
    assert chosen["joints"] == prediction.skeleton.num_joints
    assert chosen["total"] >= max(c["total"] for c in auto["candidates"]) - MARGIN
    again = predict_skeleton(vertices, faces, method="auto")
    np.testing.assert_array_equal(again.skeleton.positions, prediction.skeleton.positions)


def test_each_rule_switch_changes_only_its_own_parameters():
    default = GeometricParams()
    plain = plain_params()
    for name, (_, overrides) in RULES.items():
        off = without_rule(name)
        changed = {f.name for f in fields(GeometricParams) if getattr(off, f.name) != getattr(default, f.name)}
        assert changed == set(overrides), name
        assert all(getattr(plain, key) == value for key, value in overrides.items())
    with pytest.raises(KeyError, match="unknown geometric rule"):
        without_rule("magic")
