"""Procedural creatures for the skeleton model's training data."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from simcore.geometry.voxelize import JOINT_TEST_RESOLUTION, solid_voxels
from simcore.skeleton.tokenizer import SkeletonTokenizer
from simcore.training.card import creatures_lines
from simcore.training.creature_bodies import PLANS, creature_character
from simcore.training.skeleton_dataset import make_skeleton_sample, target_skeleton


@pytest.mark.parametrize("k", range(len(PLANS)))
def test_each_plan_is_one_closed_skin_around_its_weighted_joints(k: int) -> None:
    c = creature_character(k, np.random.default_rng([7, k]))
    weights = c.weights.toarray()
    assert np.allclose(weights.sum(1), 1.0) and weights.min() >= 0.0
    assert (weights > 0).sum(1).max() <= 4
    children = c.skeleton.children()
    leaves = [j for j in range(c.skeleton.num_joints) if not children[j]]
    assert not weights[:, leaves].any(), "an end joint carries weight"
    inner = [j for j in range(c.skeleton.num_joints) if children[j]]
    assert weights[:, inner].any(0).mean() >= 0.8, "joints that turn bones bind no vertex"  # a stub inside a bulb may not
    mesh = trimesh.Trimesh(c.vertices, c.faces)
    assert mesh.body_count == 1 and mesh.volume > 0
    target = target_skeleton(c)
    assert target.num_joints == len(inner)
    solid = solid_voxels(c.vertices, c.faces, resolution=JOINT_TEST_RESOLUTION)
    assert solid.inside(target.positions).all()


def test_plans_have_their_limbs() -> None:
    names = {PLANS[k]: creature_character(k, np.random.default_rng(k)).skeleton.names for k in range(len(PLANS))}
    legs = {plan: len({n.rsplit("_", 1)[0] for n in joint_names if n.startswith("leg_")})
            for plan, joint_names in names.items()}
    assert legs == {"quadruped": 4, "insect": 6, "spider": 8, "bird": 2, "snake": 0, "fish": 0, "dragon": 4, "raptor": 2}
    assert any(n.startswith("wing_") for n in names["bird"]) and any(n.startswith("wing_") for n in names["dragon"])
    assert not any(n.startswith("wing_") for n in names["quadruped"])


def test_a_seed_gives_one_creature_and_another_seed_another() -> None:
    a, b, c = (creature_character(3, np.random.default_rng(s)) for s in (1, 1, 2))
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.skeleton.positions, b.skeleton.positions)
    assert a.skeleton.positions.shape != c.skeleton.positions.shape or not np.allclose(a.skeleton.positions, c.skeleton.positions)


def test_a_creature_tokenizes_into_a_training_sample() -> None:
    c = creature_character(2, np.random.default_rng(0))
    sample = make_skeleton_sample(c, np.random.default_rng(0), 512, SkeletonTokenizer(max_length=512))
    assert len(sample.joints) == target_skeleton(c).num_joints and sample.points.shape == (512, 6)
    assert sample.category == "other"
    assert SkeletonTokenizer.read_class(sample.tokens) == "none"  # their own class, apart from the artists' rigs


def test_model_cards_list_the_creatures_only_when_the_data_has_them() -> None:
    assert creatures_lines({"creatures": 0, "anny_variants": 3}) == []
    (line,) = creatures_lines({"creatures": 240, "anny_variants": 3})
    assert line.startswith("- 240 procedural creatures") and "3 variants each" in line
    assert all(plan in line for plan in PLANS)
