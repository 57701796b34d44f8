"""USD materials and timing, read back with usd-core: textured UsdPreviewSurface bound to every mesh, the texture
inside the .usdz, whole time codes per second equal to the clip's rate, and usd-core's validators passing."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest

from simcore.io.gltf_document import GltfDocument
from simcore.io.usd_skel_writer import write_usd_skel
from simcore.io.usd_validate import validate_usd_file
from simcore.motion.timing import resample
from tests.simcore.io.rig_export_fixtures import (
    bend_animation,
    capsule_glb,
    chain_skeleton,
    falloff_weights,
    glb_with_json,
)

pytest.importorskip("pxr")


def _bound_surface(mesh_prim):
    """(material, its UsdPreviewSurface shader) bound to `mesh_prim`."""
    from pxr import UsdShade

    material, _ = UsdShade.MaterialBindingAPI(mesh_prim).ComputeBoundMaterial()
    assert material, f"{mesh_prim.GetPath()} has no bound material"
    source = material.GetSurfaceOutput().GetConnectedSources()[0][0].source
    shader = UsdShade.Shader(source.GetPrim())
    assert shader.GetIdAttr().Get() == "UsdPreviewSurface"
    return material, shader


def _texture_of(shader, input_name: str):
    from pxr import UsdShade

    source = shader.GetInput(input_name).GetConnectedSources()[0][0].source
    texture = UsdShade.Shader(source.GetPrim())
    assert texture.GetIdAttr().Get() == "UsdUVTexture"
    return texture


def _meshes(stage):
    from pxr import UsdGeom

    return [p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)]


def test_textured_upload_gives_bound_preview_surface_and_packed_texture(tmp_path):
    from pxr import Usd

    glb, mesh = capsule_glb()
    skeleton = chain_skeleton(4)
    written = write_usd_skel(glb, skeleton, falloff_weights(mesh.vertices, skeleton, keep=3),
                             tmp_path / "rigged.usdc", usdz_path=tmp_path / "rigged.usdz")
    usdc, usdz, texture_file = written
    doc = GltfDocument.from_bytes(glb)
    image = doc.view_bytes(doc.items("images")[0]["bufferView"])[0]
    assert texture_file.read_bytes() == image
    with zipfile.ZipFile(usdz) as package:
        assert package.read("texture_0.png") == image
    for path in (usdc, usdz):
        result = validate_usd_file(path)
        assert result.ok and not result.warnings, result.errors + result.warnings
        stage = Usd.Stage.Open(str(path))
        (mesh_prim,) = _meshes(stage)
        _, surface = _bound_surface(mesh_prim)
        texture = _texture_of(surface, "diffuseColor")
        asset = texture.GetInput("file").Get()
        assert asset.path == "./texture_0.png" and asset.resolvedPath, asset
        assert texture.GetInput("sourceColorSpace").Get() == "sRGB"
        scale = texture.GetInput("scale").Get()  # the glTF baseColorFactor multiplies the texture
        np.testing.assert_allclose(list(scale)[:3], np.array([200, 180, 160]) / 255, atol=1e-3)


def test_untextured_material_keeps_its_factors(tmp_path):
    from pxr import Usd

    def paint(doc: dict) -> None:
        doc["materials"] = [{"name": "paint", "alphaMode": "BLEND", "emissiveFactor": [0.1, 0.0, 0.0],
                             "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 0.6, 0.5],
                                                      "metallicFactor": 0.3, "roughnessFactor": 0.7}}]
        doc["meshes"][0]["primitives"][0]["material"] = 0

    plain, mesh = capsule_glb(textured=False)
    skeleton = chain_skeleton(3)
    path = write_usd_skel(glb_with_json(plain, paint), skeleton, falloff_weights(mesh.vertices, skeleton, keep=2),
                          tmp_path / "plain.usdc")[0]
    assert validate_usd_file(path).ok
    stage = Usd.Stage.Open(str(path))
    (mesh_prim,) = _meshes(stage)
    material, surface = _bound_surface(mesh_prim)
    assert material.GetPath().name == "paint"
    values = {name: surface.GetInput(name).Get() for name in ("diffuseColor", "opacity", "metallic", "roughness",
                                                               "emissiveColor")}
    np.testing.assert_allclose(list(values.pop("diffuseColor")), [0.2, 0.4, 0.6], atol=1e-6)
    np.testing.assert_allclose(list(values.pop("emissiveColor")), [0.1, 0.0, 0.0], atol=1e-6)
    assert values == pytest.approx({"opacity": 0.5, "metallic": 0.3, "roughness": 0.7})


def test_fox_usdz_carries_its_texture(dev_assets, tmp_path):
    import trimesh
    from pxr import Usd

    from simcore.io.gltf_rig import read_rigged_asset

    asset = read_rigged_asset(GltfDocument.from_bytes((dev_assets / "fox.glb").read_bytes()))
    static = trimesh.exchange.gltf.export_glb(trimesh.load(dev_assets / "fox.glb", process=False, force="scene"),
                                              include_normals=True)  # the ingest contract: transforms baked
    written = write_usd_skel(static, asset.skeleton, asset.weights, tmp_path / "fox.usdc",
                             usdz_path=tmp_path / "fox.usdz")
    assert validate_usd_file(written[1]).ok
    with zipfile.ZipFile(written[1]) as package:
        assert any(name.startswith("texture_") for name in package.namelist())
    stage = Usd.Stage.Open(str(written[1]))
    for mesh_prim in _meshes(stage):
        _, surface = _bound_surface(mesh_prim)
        assert _texture_of(surface, "diffuseColor").GetInput("file").Get().resolvedPath


@pytest.mark.parametrize(("source_fps", "expected"), [(1 / 0.0083333, 120), (24.0, 24), (29.97, 30)])
def test_animated_usd_plays_at_the_clips_whole_rate(tmp_path, source_fps, expected):
    from pxr import Usd

    glb, mesh = capsule_glb()
    skeleton = chain_skeleton(4)
    clip = resample(bend_animation(skeleton, frames=30, fps=source_fps))
    assert clip.fps == expected
    written = write_usd_skel(glb, skeleton, falloff_weights(mesh.vertices, skeleton, keep=3),
                             tmp_path / "animated.usdc", animation=clip, usdz_path=tmp_path / "animated.usdz")
    for path in written[:2]:
        assert validate_usd_file(path).ok
        stage = Usd.Stage.Open(str(path))
        tcps = stage.GetTimeCodesPerSecond()
        assert tcps == expected and float(tcps).is_integer() and stage.GetFramesPerSecond() == expected
        assert stage.GetEndTimeCode() == clip.num_frames - 1


def test_rounded_frame_time_keeps_every_frame():
    skeleton = chain_skeleton(3)
    clip = bend_animation(skeleton, frames=50, fps=1 / 0.0083333)
    out = resample(clip)
    assert out.fps == 120.0 and out.num_frames == 50
    np.testing.assert_array_equal(out.rotations, clip.rotations)
