"""glTF metallic-roughness materials as UsdPreviewSurface networks, with their textures as files beside the USD.

Each glTF material becomes /Character/Materials/<name>: a UsdPreviewSurface fed by factors and, where the
material has them, UsdUVTexture readers of the base colour (sRGB; its alpha drives opacity unless the
material is OPAQUE), metallic-roughness (raw; metal in blue, roughness in green, as glTF packs them),
normal (raw, scaled to -1..1) and emissive (sRGB) images, all read through the mesh's `st` primvar.
Images are written once per file name (`texture_<image>.png|jpg`) next to the USD layer and referenced
relatively, so `UsdUtils.CreateNewUsdzPackage` packs them into the .usdz. Images that USD cannot read in a
package (WebP, KTX2) are left out and the factor alone is used.
"""

from __future__ import annotations

import base64
from pathlib import Path

from simcore.io.gltf_document import GltfDocument

PNG_MAGIC, JPEG_MAGIC = b"\x89PNG\r\n\x1a\n", b"\xff\xd8\xff"
WRAP_MODES = {33071: "clamp", 33648: "mirror", 10497: "repeat"}  # glTF sampler wrap → UsdUVTexture wrap


def _image_bytes(doc: GltfDocument, image: dict) -> bytes | None:
    if "bufferView" in image:
        return doc.view_bytes(int(image["bufferView"]))[0]
    uri = str(image.get("uri", ""))
    if uri.startswith("data:") and ";base64," in uri:
        return base64.b64decode(uri.split(",", 1)[1])
    return None  # external URIs were dropped unread at ingest


def write_texture_files(doc: GltfDocument, directory: Path) -> dict[int, str]:
    """Write every PNG/JPEG image of `doc` into `directory`; returns image index → file name (beside the layer)."""
    out: dict[int, str] = {}
    for i, image in enumerate(doc.items("images")):
        data = _image_bytes(doc, image)
        if data is None:
            continue
        ext = "png" if data.startswith(PNG_MAGIC) else "jpg" if data.startswith(JPEG_MAGIC) else None
        if ext is None:
            continue
        name = f"texture_{i}.{ext}"
        path = Path(directory) / name
        if not path.is_file() or path.read_bytes() != data:
            path.write_bytes(data)
        out[i] = name
    return out


def _texture_image(doc: GltfDocument, slot: dict | None, files: dict[int, str]) -> tuple[str, dict] | None:
    """(file name, sampler) of a material's texture slot, or None when it has no usable image."""
    if not slot or "index" not in slot:
        return None
    textures = doc.items("textures")
    index = int(slot["index"])
    if not 0 <= index < len(textures) or textures[index].get("source") not in files:
        return None
    samplers = doc.items("samplers")
    sampler_index = textures[index].get("sampler")
    sampler = samplers[sampler_index] if isinstance(sampler_index, int) and 0 <= sampler_index < len(samplers) else {}
    return files[textures[index]["source"]], sampler


class _Network:
    """Builds one material's shader network under its Material prim."""

    def __init__(self, stage, material, path: str):
        from pxr import Sdf, UsdShade

        self.stage, self.material, self.path = stage, material, path
        self.surface = UsdShade.Shader.Define(stage, f"{path}/PreviewSurface")
        self.surface.CreateIdAttr("UsdPreviewSurface")
        material.CreateSurfaceOutput().ConnectToSource(self.surface.ConnectableAPI(), "surface")
        reader = UsdShade.Shader.Define(stage, f"{path}/TexCoordReader")
        reader.CreateIdAttr("UsdPrimvarReader_float2")
        varname = material.CreateInput("frame:stPrimvarName", Sdf.ValueTypeNames.String)
        varname.Set("st")
        reader.CreateInput("varname", Sdf.ValueTypeNames.String).ConnectToSource(varname)
        self.st = reader.CreateOutput("result", Sdf.ValueTypeNames.Float2)

    def texture(self, name: str, image: tuple[str, dict], color_space: str,
                scale: tuple[float, ...] | None = None, bias: tuple[float, ...] | None = None):
        """A UsdUVTexture reading `image` through the st reader; returns the shader."""
        from pxr import Gf, Sdf, UsdShade

        file, sampler = image
        shader = UsdShade.Shader.Define(self.stage, f"{self.path}/{name}")
        shader.CreateIdAttr("UsdUVTexture")
        shader.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(f"./{file}"))
        shader.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(self.st)
        shader.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set(color_space)
        shader.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set(WRAP_MODES.get(sampler.get("wrapS", 10497), "repeat"))
        shader.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set(WRAP_MODES.get(sampler.get("wrapT", 10497), "repeat"))
        if scale is not None:
            shader.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(*scale))
        if bias is not None:
            shader.CreateInput("bias", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(*bias))
        return shader

    def connect(self, input_name: str, input_type, shader, output: str) -> None:
        """Feed the surface's `input_name` from a texture's output (rgb: float3, one channel: float)."""
        from pxr import Sdf

        output_type = Sdf.ValueTypeNames.Float3 if output == "rgb" else Sdf.ValueTypeNames.Float
        source = shader.CreateOutput(output, output_type)
        self.surface.CreateInput(input_name, input_type).ConnectToSource(source)


def _define_material(stage, doc: GltfDocument, gltf_material: dict, path: str, files: dict[int, str]):
    from pxr import Gf, Sdf, UsdShade

    types = Sdf.ValueTypeNames
    material = UsdShade.Material.Define(stage, path)
    net = _Network(stage, material, path)
    surface = net.surface
    pbr = gltf_material.get("pbrMetallicRoughness", {})
    base = [float(c) for c in pbr.get("baseColorFactor", [1.0, 1.0, 1.0, 1.0])]
    alpha_mode = gltf_material.get("alphaMode", "OPAQUE")
    base_image = _texture_image(doc, pbr.get("baseColorTexture"), files)
    if base_image is not None:
        tex = net.texture("BaseColorTexture", base_image, "sRGB", scale=tuple(base))
        net.connect("diffuseColor", types.Color3f, tex, "rgb")
        if alpha_mode != "OPAQUE":
            net.connect("opacity", types.Float, tex, "a")
    else:
        surface.CreateInput("diffuseColor", types.Color3f).Set(Gf.Vec3f(*base[:3]))
        if alpha_mode != "OPAQUE":
            surface.CreateInput("opacity", types.Float).Set(base[3])
    if alpha_mode == "MASK":
        surface.CreateInput("opacityThreshold", types.Float).Set(float(gltf_material.get("alphaCutoff", 0.5)))
    metal, rough = float(pbr.get("metallicFactor", 1.0)), float(pbr.get("roughnessFactor", 1.0))
    mr_image = _texture_image(doc, pbr.get("metallicRoughnessTexture"), files)
    if mr_image is not None:
        tex = net.texture("MetallicRoughnessTexture", mr_image, "raw", scale=(1.0, rough, metal, 1.0))
        net.connect("metallic", types.Float, tex, "b")
        net.connect("roughness", types.Float, tex, "g")
    else:
        surface.CreateInput("metallic", types.Float).Set(metal)
        surface.CreateInput("roughness", types.Float).Set(rough)
    normal_slot = gltf_material.get("normalTexture")
    normal_image = _texture_image(doc, normal_slot, files)
    if normal_image is not None and normal_slot is not None:  # an image comes from a slot
        k = float(normal_slot.get("scale", 1.0))
        tex = net.texture("NormalTexture", normal_image, "raw", scale=(2 * k, 2 * k, 2.0, 1.0), bias=(-k, -k, -1.0, 0.0))
        net.connect("normal", types.Normal3f, tex, "rgb")
    emissive = [float(c) for c in gltf_material.get("emissiveFactor", [0.0, 0.0, 0.0])]
    emissive_image = _texture_image(doc, gltf_material.get("emissiveTexture"), files)
    if emissive_image is not None:
        tex = net.texture("EmissiveTexture", emissive_image, "sRGB", scale=(*emissive, 1.0))
        net.connect("emissiveColor", types.Color3f, tex, "rgb")
    elif any(emissive):
        surface.CreateInput("emissiveColor", types.Color3f).Set(Gf.Vec3f(*emissive))
    return material


def define_materials(stage, doc: GltfDocument, root: str, files: dict[int, str]) -> list:
    """A UsdShade.Material per glTF material (same order) under `root`/Materials; [] when there are none."""
    from pxr import UsdGeom

    from simcore.io.usd_skel_writer import usd_identifier

    materials = doc.items("materials")
    if not materials:
        return []
    UsdGeom.Scope.Define(stage, f"{root}/Materials")
    taken: set[str] = set()
    out = []
    for i, gltf_material in enumerate(materials):
        name = usd_identifier(str(gltf_material.get("name") or f"material_{i}"), taken)
        out.append(_define_material(stage, doc, gltf_material, f"{root}/Materials/{name}", files))
    return out


def bind_material(mesh, material) -> None:
    """Bind `material` to `mesh` (applies MaterialBindingAPI, as UsdShade's validators require)."""
    from pxr import UsdShade

    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
