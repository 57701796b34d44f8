"""UsdSkel export: rigged.usdc (+ .usdz), animated.usdc (SkelAnimation) and refined.usdc (time-sampled points).

Layout written (metersPerUnit 1, upAxis Y, defaultPrim /Character):
  /Character                SkelRoot
  /Character/Skeleton       Skeleton: joints (USD-safe unique names as paths), bindTransforms, restTransforms
  /Character/Animation      SkelAnimation (animated/refined only), the Skeleton's skel:animationSource
  /Character/Materials/<m>  UsdPreviewSurface per glTF material; textures written beside the file (usd_materials)
  /Character/Geometry/<m>   Mesh per glTF triangle primitive: points, faceVertexIndices, normals, primvars:st,
                            primvars:skel:jointIndices/jointWeights (elementSize = influences), geomBindTransform
Refined files are animated files whose meshes also carry the refinement as UsdSkel BlendShapes (applied in bind
space before skinning, as glTF morph targets are): the compact form of morph_compact (basis shapes, and per key
a residual shape with pointIndices for the vertices the basis misses), keyed at most `refined_rate` times a
second and weighted by the SkelAnimation's time-sampled blendShapeWeights (linear between keys).
Matrices: ours are column-vector 4x4; USD's Gf.Matrix4d is row-vector, hence the transposes. Quaternions:
ours xyzw, USD's Gf.Quatf real-first. pxr is imported lazily (worker-only dependency).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from simcore.errors import InvalidInput
from simcore.io.file_layout import file_animation, file_forest
from simcore.io.gltf_rig import primitive_triangles
from simcore.io.mesh_layout import MeshLayout, read_mesh_layout
from simcore.io.skin_influences import Influences, top_influences
from simcore.io.usd_materials import bind_material, define_materials, write_texture_files
from simcore.skeleton.kinematics import bind_matrices, rest_local_matrices
from simcore.skeleton.types import Skeleton

if TYPE_CHECKING:
    from simcore.motion.types import JointAnimation

ROOT = "/Character"
BLEND_BASIS_VERTEX_BYTES = 12.0  # a float3 offset
BLEND_RESIDUAL_VERTEX_BYTES = 16.0  # a float3 offset and its int point index


def usd_identifier(name: str, taken: set[str]) -> str:
    """A valid USD prim name from `name`, unique within `taken` (which it is added to)."""
    base = re.sub(r"[^A-Za-z0-9_]", "_", name) or "joint"
    if base[0].isdigit():
        base = "_" + base
    out, k = base, 1
    while out in taken:
        out, k = f"{base}_{k}", k + 1
    taken.add(out)
    return out


def joint_paths(skeleton: Skeleton) -> list[str]:
    """USD joint path tokens ("hips/spine/chest"), one per joint in skeleton order."""
    taken: set[str] = set()
    out: list[str] = []
    for j, name in enumerate(skeleton.names):
        token = usd_identifier(name, taken)
        p = int(skeleton.parents[j])
        out.append(token if p < 0 else f"{out[p]}/{token}")
    return out


def _matrices(mats: np.ndarray):
    from pxr import Gf, Vt

    return Vt.Matrix4dArray([Gf.Matrix4d(m.T.tolist()) for m in mats])


def _base_color(doc, prim: dict) -> list[float] | None:
    materials = doc.items("materials")
    index = prim.get("material")
    if index is None or not 0 <= int(index) < len(materials):
        return None
    factor = materials[int(index)].get("pbrMetallicRoughness", {}).get("baseColorFactor")
    return [float(c) for c in factor[:3]] if factor else None


def _define_meshes(stage, layout: MeshLayout, infl: Influences | None, skel_path: str | None,
                   materials: list) -> list:
    """One UsdGeom.Mesh per triangle primitive, bound to its material; returns [(mesh, vertex slice)]."""
    from pxr import Gf, Sdf, UsdGeom, UsdSkel, Vt

    doc, out = layout.doc, []
    taken: set[str] = set()
    UsdGeom.Scope.Define(stage, f"{ROOT}/Geometry")
    for s in layout.slices:
        prim = doc.items("meshes")[s.mesh]["primitives"][s.primitive]
        faces = primitive_triangles(doc, prim, s.count)
        if len(faces) == 0:
            continue  # points/lines primitives have no USD Mesh equivalent
        name = usd_identifier(f"{layout.mesh_node_names[s.mesh]}_{s.primitive}", taken)
        mesh = UsdGeom.Mesh.Define(stage, f"{ROOT}/Geometry/{name}")
        rows = slice(s.start, s.start + s.count)
        points = layout.vertices[rows].astype(np.float32)
        mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
        mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(faces), 3, np.int32)))
        mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(faces.astype(np.int32).reshape(-1)))
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        mesh.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(*points.min(0).tolist()), Gf.Vec3f(*points.max(0).tolist())]))
        attrs = prim.get("attributes", {})
        if "NORMAL" in attrs:
            mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(doc.accessor(attrs["NORMAL"]).astype(np.float32)))
            mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
        api = UsdGeom.PrimvarsAPI(mesh)
        if "TEXCOORD_0" in attrs:
            uv = doc.accessor(attrs["TEXCOORD_0"]).astype(np.float32)
            uv[:, 1] = 1.0 - uv[:, 1]  # glTF's v runs down the image, USD's st up
            st = api.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex)
            st.Set(Vt.Vec2fArray.FromNumpy(uv))
        color = _base_color(doc, prim)
        if color is not None:
            mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set(Vt.Vec3fArray([Gf.Vec3f(*color)]))
        if isinstance(prim.get("material"), int) and 0 <= prim["material"] < len(materials):
            bind_material(mesh, materials[prim["material"]])
        if infl is not None and skel_path is not None:
            binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
            binding.CreateSkeletonRel().SetTargets([Sdf.Path(skel_path)])
            k = infl.joints.shape[1]
            binding.CreateJointIndicesPrimvar(False, k).Set(Vt.IntArray.FromNumpy(infl.joints[rows].astype(np.int32).reshape(-1)))
            binding.CreateJointWeightsPrimvar(False, k).Set(Vt.FloatArray.FromNumpy(infl.weights[rows].reshape(-1)))
            binding.CreateGeomBindTransformAttr(Gf.Matrix4d(1.0))
            _define_blend_shapes(stage, mesh, binding, doc, prim, doc.items("meshes")[s.mesh])
        out.append((mesh, rows))
    return out


def _define_blend_shapes(stage, mesh, binding, doc, prim: dict, gltf_mesh: dict) -> None:
    """The upload's morph targets as UsdSkel BlendShapes under the mesh, named as in mesh.glb's targetNames."""
    from pxr import Sdf, UsdSkel, Vt

    targets = prim.get("targets", [])
    if not targets:
        return
    given = gltf_mesh["extras"]["targetNames"]  # ingest names every target (input_morphs.target_defaults)
    taken: set[str] = set()
    names, paths = [], []
    for target, given_name in zip(targets, given):
        name = usd_identifier(str(given_name), taken)
        shape = UsdSkel.BlendShape.Define(stage, mesh.GetPath().AppendChild(name))
        offsets = doc.accessor(target["POSITION"]).astype(np.float32) if "POSITION" in target else None
        shape.CreateOffsetsAttr(Vt.Vec3fArray.FromNumpy(offsets if offsets is not None else np.zeros((0, 3), np.float32)))
        if "NORMAL" in target:
            shape.CreateNormalOffsetsAttr(Vt.Vec3fArray.FromNumpy(doc.accessor(target["NORMAL"]).astype(np.float32)))
        names.append(name)
        paths.append(Sdf.Path(shape.GetPath()))
    binding.CreateBlendShapesAttr(names)
    binding.CreateBlendShapeTargetsRel().SetTargets(paths)


def _define_animation(stage, skeleton: Skeleton, joints: list[str], animation: JointAnimation) -> str:
    from pxr import Gf, UsdSkel, Vt

    from simcore.io.joint_tracks import joint_tracks

    tracks = joint_tracks(skeleton, animation)
    anim = UsdSkel.Animation.Define(stage, f"{ROOT}/Animation")
    anim.CreateJointsAttr(joints)
    rot_attr, trans_attr = anim.CreateRotationsAttr(), anim.CreateTranslationsAttr()
    anim.CreateScalesAttr().Set(Vt.Vec3hArray([Gf.Vec3h(1, 1, 1)] * skeleton.num_joints))
    for t in range(len(tracks.times)):
        q = tracks.rotations[t]
        rot_attr.Set(Vt.QuatfArray([Gf.Quatf(float(w), float(x), float(y), float(z)) for x, y, z, w in q]), t)
        trans_attr.Set(Vt.Vec3fArray.FromNumpy(tracks.translations[t].astype(np.float32)), t)
    stage.SetTimeCodesPerSecond(float(animation.fps))  # the motion stage makes it a whole number
    stage.SetFramesPerSecond(float(animation.fps))
    stage.SetStartTimeCode(0)
    stage.SetEndTimeCode(max(len(tracks.times) - 1, 0))
    return str(anim.GetPath())


def _define_refinement(stage, meshes: list, layout: MeshLayout, skeleton: Skeleton, infl: Influences,
                       animation: JointAnimation, refined: np.ndarray, rate: float | None,
                       tolerance: float | None) -> None:
    """The refinement as blend shapes on every mesh and their weights on the SkelAnimation (see module doc)."""
    from pxr import Sdf, UsdSkel, Vt

    from simcore.io.glb_animation import morph_key_frames
    from simcore.io.morph_bake import bind_space_offsets
    from simcore.io.morph_compact import TOLERANCE, compact_offsets

    keys = morph_key_frames(len(refined), len(refined), animation.fps, rate)
    offsets = bind_space_offsets(layout.vertices, skeleton, infl, animation, refined[keys], frames=keys)
    size = float(np.ptp(layout.vertices, axis=0).max()) if len(layout.vertices) else 0.0
    compact = compact_offsets(offsets, (TOLERANCE if tolerance is None else tolerance) * size,
                              BLEND_BASIS_VERTEX_BYTES, BLEND_RESIDUAL_VERTEX_BYTES)
    with_residual = [i for i in range(len(keys)) if len(compact.residual_rows[i])]
    names = [f"refine_basis_{j}" for j in range(compact.rank)] + [f"refine_frame_{int(keys[i])}" for i in with_residual]
    for mesh, rows in meshes:
        binding = UsdSkel.BindingAPI(mesh.GetPrim())
        given = list(binding.GetBlendShapesAttr().Get() or [])
        targets = list(binding.GetBlendShapeTargetsRel().GetTargets())
        for j in range(compact.rank):
            shape = UsdSkel.BlendShape.Define(stage, mesh.GetPath().AppendChild(names[j]))
            shape.CreateOffsetsAttr(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(compact.basis[j, rows])))
            given.append(names[j])
            targets.append(Sdf.Path(shape.GetPath()))
        for col, i in enumerate(with_residual):
            r = compact.residual_rows[i]
            inside = (r >= rows.start) & (r < rows.stop)
            if not inside.any():
                continue
            name = names[compact.rank + col]
            shape = UsdSkel.BlendShape.Define(stage, mesh.GetPath().AppendChild(name))
            shape.CreateOffsetsAttr(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(compact.residual_values[i][inside])))
            shape.CreatePointIndicesAttr(Vt.IntArray.FromNumpy((r[inside] - rows.start).astype(np.int32)))
            given.append(name)
            targets.append(Sdf.Path(shape.GetPath()))
        binding.CreateBlendShapesAttr(given)
        binding.CreateBlendShapeTargetsRel().SetTargets(targets)
    if not names:  # no offsets at all
        return
    anim = UsdSkel.Animation.Get(stage, f"{ROOT}/Animation")
    anim.CreateBlendShapesAttr(names)
    weights = np.zeros((len(keys), len(names)), np.float32)
    weights[:, :compact.rank] = compact.coefficients
    weights[with_residual, compact.rank + np.arange(len(with_residual))] = 1.0
    attr = anim.CreateBlendShapeWeightsAttr()
    for i, f in enumerate(keys):
        attr.Set(Vt.FloatArray.FromNumpy(weights[i]), float(f))


def write_usd_skel(
    mesh_glb: bytes,
    skeleton: Skeleton,
    weights: sp.spmatrix,
    out_path: Path,
    *,
    max_influences: int = 4,
    animation: JointAnimation | None = None,
    refined_frames: np.ndarray | None = None,
    refined_rate: float | None = None,
    refined_tolerance: float | None = None,
    usdz_path: Path | None = None,
) -> list[Path]:
    """Write a UsdSkel file (.usdc/.usda by extension) and optionally a .usdz package of it.

    mesh_glb / skeleton / weights: as for write_rigged_glb ((V, J) weights in mesh.glb vertex order).
    animation:      clip bound as the Skeleton's animationSource (time code k = frame k, at its fps).
    refined_frames: (T, V, 3) float world positions at animation frames 0..T-1; written as blend shapes of the
                    skinned meshes (needs `animation`); refined_rate: most keys per second (None: every frame);
                    refined_tolerance: vertex error the compact form may add, as a fraction of the bind pose's
                    largest bounding-box side (default morph_compact.TOLERANCE).
    Returns the written paths: the USD files, then the texture files (texture_<i>.png|jpg) beside them that
    the .usdc references and the .usdz holds.
    """
    from pxr import Kind, Sdf, Usd, UsdGeom, UsdSkel, UsdUtils

    skeleton.validate()
    forest = file_forest(skeleton)  # a kept rig's extra roots stay roots (UsdSkel allows a forest)
    if animation is not None:
        animation = file_animation(skeleton, forest, animation)
    skeleton = forest
    layout = read_mesh_layout(mesh_glb)
    w = sp.csr_matrix(weights)
    if w.shape != (len(layout.vertices), skeleton.num_joints):
        raise InvalidInput(f"weights {w.shape} do not match {len(layout.vertices)} vertices x "
                           f"{skeleton.num_joints} joints", code="export_shape_mismatch", field="weights")
    if refined_frames is not None:
        refined_frames = np.asarray(refined_frames, dtype=np.float32)
        if animation is None or refined_frames.shape[1:] != layout.vertices.shape:
            raise InvalidInput("refined frames need their animation and one position per vertex",
                               code="export_shape_mismatch", field="refined_frames")
    infl = top_influences(w, max_influences, layout.vertices, skeleton.positions)

    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageMetersPerUnit(stage, UsdGeom.LinearUnits.meters)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    root = UsdSkel.Root.Define(stage, ROOT)
    stage.SetDefaultPrim(root.GetPrim())
    Usd.ModelAPI(root.GetPrim()).SetKind(Kind.Tokens.component)
    skel = UsdSkel.Skeleton.Define(stage, f"{ROOT}/Skeleton")
    joints = joint_paths(skeleton)
    skel.CreateJointsAttr(joints)
    skel.CreateJointNamesAttr(list(skeleton.names))
    skel.CreateBindTransformsAttr(_matrices(bind_matrices(skeleton)))
    skel.CreateRestTransformsAttr(_matrices(rest_local_matrices(skeleton)))
    if animation is not None:
        anim_path = _define_animation(stage, skeleton, joints, animation)
        UsdSkel.BindingAPI.Apply(skel.GetPrim()).CreateAnimationSourceRel().SetTargets([Sdf.Path(anim_path)])
    out_path = Path(out_path)
    textures = write_texture_files(layout.doc, out_path.parent)
    materials = define_materials(stage, layout.doc, ROOT, textures)
    meshes = _define_meshes(stage, layout, infl, str(skel.GetPath()), materials)
    if refined_frames is not None and animation is not None:
        _define_refinement(stage, meshes, layout, skeleton, infl, animation, refined_frames, refined_rate,
                           refined_tolerance)
    out_path.unlink(missing_ok=True)
    stage.GetRootLayer().Export(str(out_path))
    written = [out_path]
    if usdz_path is not None:
        Path(usdz_path).unlink(missing_ok=True)
        if not UsdUtils.CreateNewUsdzPackage(Sdf.AssetPath(str(out_path)), str(usdz_path)):
            raise InvalidInput(f"could not package {out_path.name} as usdz", code="export_failed", field="usdz")
        written.append(Path(usdz_path))
    return written + [out_path.parent / name for name in textures.values()]
