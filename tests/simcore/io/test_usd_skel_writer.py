"""UsdSkel exports: compliance checks pass, UsdSkel itself skins our file like our LBS does."""

from __future__ import annotations

import numpy as np
import pytest

from simcore.io.joint_tracks import joint_tracks
from simcore.io.usd_skel_writer import joint_paths, write_usd_skel
from simcore.io.usd_validate import validate_usd_file
from simcore.skeleton.types import Skeleton
from simcore.skinning.lbs import linear_blend
from tests.simcore.io.rig_export_fixtures import bend_animation, capsule_glb, chain_skeleton, falloff_weights

pxr = pytest.importorskip("pxr")


@pytest.fixture(scope="module")
def rig():
    glb, mesh = capsule_glb()
    skeleton = chain_skeleton(4)
    return glb, mesh, skeleton, falloff_weights(mesh.vertices, skeleton, keep=3), bend_animation(skeleton)


def test_rigged_usdc_and_usdz_pass_compliance(rig, tmp_path):
    from pxr import Usd, UsdGeom, UsdSkel

    glb, mesh, skeleton, weights, _ = rig
    written = write_usd_skel(glb, skeleton, weights, tmp_path / "rigged.usdc", usdz_path=tmp_path / "rigged.usdz")
    assert [p.name for p in written] == ["rigged.usdc", "rigged.usdz", "texture_0.png"]
    for path in written[:2]:
        result = validate_usd_file(path)
        assert result.ok and not result.warnings, result.errors + result.warnings
    stage = Usd.Stage.Open(str(written[0]))
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0 and UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y
    skel = UsdSkel.Skeleton(stage.GetPrimAtPath("/Character/Skeleton"))
    assert list(skel.GetJointsAttr().Get()) == ["joint_0", "joint_0/joint_1", "joint_0/joint_1/joint_2",
                                                "joint_0/joint_1/joint_2/joint_3"]
    mesh_prim = next(p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh))
    binding = UsdSkel.BindingAPI(mesh_prim)
    assert binding.GetJointIndicesPrimvar().GetElementSize() == 4
    assert len(UsdGeom.Mesh(mesh_prim).GetPointsAttr().Get()) == len(mesh.vertices)
    st = UsdGeom.PrimvarsAPI(mesh_prim).GetPrimvar("st").Get()
    assert len(st) == len(mesh.vertices)


def test_usdskel_skins_the_animated_file_like_our_lbs(rig, tmp_path):
    from pxr import Usd, UsdGeom, UsdSkel

    glb, mesh, skeleton, weights, animation = rig
    path = write_usd_skel(glb, skeleton, weights, tmp_path / "animated.usdc", animation=animation)[0]
    assert validate_usd_file(path).ok
    stage = Usd.Stage.Open(str(path))
    assert stage.GetTimeCodesPerSecond() == animation.fps and stage.GetEndTimeCode() == animation.num_frames - 1
    cache = UsdSkel.Cache()
    root = UsdSkel.Root(stage.GetPrimAtPath("/Character"))
    cache.Populate(root, Usd.PrimDefaultPredicate)
    skel_query = cache.GetSkelQuery(UsdSkel.Skeleton(stage.GetPrimAtPath("/Character/Skeleton")))
    mesh_prim = next(p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh))
    skinning = cache.GetSkinningQuery(mesh_prim)
    ours = linear_blend(mesh.vertices, weights, joint_tracks(skeleton, animation).skin_matrices(skeleton))
    for t in (0, 6, 11):
        xforms = skel_query.ComputeSkinningTransforms(t)
        points = UsdGeom.Mesh(mesh_prim).GetPointsAttr().Get()
        assert skinning.ComputeSkinnedPoints(xforms, points, t)
        np.testing.assert_allclose(np.asarray(points), ours[t], atol=1e-5)


def _usd_refined_points(stage, t: float) -> np.ndarray:
    """What UsdSkel shows at time t: the mesh's blend shapes at the animation's weights, then skinned."""
    from pxr import Usd, UsdGeom, UsdSkel, Vt

    cache = UsdSkel.Cache()
    cache.Populate(UsdSkel.Root(stage.GetPrimAtPath("/Character")), Usd.PrimDefaultPredicate)
    skel_query = cache.GetSkelQuery(UsdSkel.Skeleton(stage.GetPrimAtPath("/Character/Skeleton")))
    mesh_prim = next(p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh))
    skinning = cache.GetSkinningQuery(mesh_prim)
    anim = UsdSkel.Animation(stage.GetPrimAtPath("/Character/Animation"))
    by_name = dict(zip(anim.GetBlendShapesAttr().Get(), anim.GetBlendShapeWeightsAttr().Get(t)))
    binding = UsdSkel.BindingAPI(mesh_prim)
    weights = Vt.FloatArray([by_name.get(n, 0.0) for n in binding.GetBlendShapesAttr().Get()])
    query = UsdSkel.BlendShapeQuery(binding)
    sub_weights, shape_indices, sub_indices = query.ComputeSubShapeWeights(weights)
    points = UsdGeom.Mesh(mesh_prim).GetPointsAttr().Get()
    assert query.ComputeDeformedPoints(sub_weights, shape_indices, sub_indices, query.ComputeBlendShapePointIndices(),
                                       query.ComputeSubShapePointOffsets(), points)
    assert skinning.ComputeSkinnedPoints(skel_query.ComputeSkinningTransforms(t), points, t)
    return np.asarray(points, np.float64)


def test_refined_usdc_replays_the_refinement_as_blend_shapes(rig, tmp_path):
    from pxr import Usd, UsdGeom, UsdSkel

    glb, mesh, skeleton, weights, animation = rig
    lbs = linear_blend(mesh.vertices, weights, joint_tracks(skeleton, animation).skin_matrices(skeleton))
    t = np.arange(len(lbs))[:, None, None]
    frames = (lbs + 0.01 * np.sin(t + mesh.vertices[None, :, 1:2] * 20) * np.array([1.0, 0.0, 0.5])).astype(np.float32)
    frames[6, 7] += [0.0, 0.03, 0.0]  # a lone spike on one key, which the wave's shapes do not carry
    path = write_usd_skel(glb, skeleton, weights, tmp_path / "refined.usdc", animation=animation, refined_frames=frames,
                          refined_rate=12.0)[0]
    result = validate_usd_file(path)
    assert result.ok and not result.warnings, result.errors + result.warnings
    stage = Usd.Stage.Open(str(path))
    mesh_prim = next(p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh))
    shapes = list(UsdSkel.BindingAPI(mesh_prim).GetBlendShapesAttr().Get())
    assert any(n.startswith("refine_") for n in shapes)
    size = float(np.ptp(mesh.vertices, axis=0).max())
    keys = UsdSkel.Animation(stage.GetPrimAtPath("/Character/Animation")).GetBlendShapeWeightsAttr().GetTimeSamples()
    assert keys == [0, 2, 4, 6, 8, 10, 11]  # every other frame of the 24 fps clip, and its last
    for k in (0, 6, 11):
        err = np.linalg.norm(_usd_refined_points(stage, k) - frames[k], axis=1)
        assert err.max() <= 1e-3 * size + 1e-5, (k, err.max())


def test_joint_names_become_unique_usd_paths():
    skeleton = Skeleton(np.zeros((4, 3)), np.array([-1, 0, 0, 1]), ["mixamorig:Hips", "a b", "a_b", "1st"])
    assert joint_paths(skeleton) == ["mixamorig_Hips", "mixamorig_Hips/a_b", "mixamorig_Hips/a_b_1",
                                     "mixamorig_Hips/a_b/_1st"]


def test_checker_reports_missing_stage_metadata(tmp_path):
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.CreateInMemory()
    UsdGeom.Xform.Define(stage, "/a")
    stage.GetRootLayer().Export(str(tmp_path / "bare.usda"))
    result = validate_usd_file(tmp_path / "bare.usda")
    assert not result.ok and any("upAxis" in e for e in result.errors)


def test_refinement_equal_to_lbs_adds_no_blend_shapes(rig, tmp_path):
    from pxr import Usd, UsdSkel

    glb, mesh, skeleton, weights, animation = rig
    lbs = linear_blend(mesh.vertices, weights, joint_tracks(skeleton, animation).skin_matrices(skeleton))
    path = write_usd_skel(glb, skeleton, weights, tmp_path / "refined.usdc", animation=animation, refined_frames=lbs)[0]
    assert validate_usd_file(path).ok
    stage = Usd.Stage.Open(str(path))
    assert not [p for p in stage.Traverse() if p.IsA(UsdSkel.BlendShape)]
