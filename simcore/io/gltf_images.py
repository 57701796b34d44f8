"""Texture images that point at files outside the upload (`guard1_body.png`, `C:/work/x.png`, as assimp, Collada
and older exporters write them): dropped from the glTF JSON, never opened, so the mesh still goes through.

Images, the textures left without an image and the material slots that used those textures are removed, and
the remaining indices renumbered, so the document stays valid glTF.
"""

from __future__ import annotations

from typing import Any


def _is_external(image: Any) -> bool:
    return isinstance(image, dict) and isinstance(image.get("uri"), str) and not image["uri"].startswith("data:")


def _renumber_images(texture: dict, image_map: dict[int, int | None]) -> bool:
    """Renumber a texture's image indices (its `source`, its extensions' `source`s), dropping those that point
    at a removed image (an extension left without its image goes too); True when the texture keeps an image."""
    if "source" in texture:
        new = image_map.get(texture["source"], texture["source"])
        if new is None:
            del texture["source"]
        else:
            texture["source"] = new
    extensions = texture.get("extensions") or {}
    for name, ext in list(extensions.items()):
        if isinstance(ext, dict) and "source" in ext:
            new = image_map.get(ext["source"], ext["source"])
            if new is None:
                del extensions[name]
            else:
                ext["source"] = new
    if "extensions" in texture and not extensions:
        del texture["extensions"]
    return "source" in texture or any(isinstance(e, dict) and "source" in e for e in extensions.values())


def _renumber_texture_slots(tree: Any, texture_map: dict[int, int | None]) -> None:
    """Point every textureInfo (a `...Texture` object with an `index`) at its new texture, or remove it."""
    if isinstance(tree, list):
        for item in tree:
            _renumber_texture_slots(item, texture_map)
        return
    if not isinstance(tree, dict):
        return
    for key in list(tree):
        value = tree[key]
        if key.endswith("Texture") and isinstance(value, dict) and isinstance(value.get("index"), int):
            new = texture_map.get(value["index"], value["index"])
            if new is None:
                del tree[key]
            else:
                value["index"] = new
        else:
            _renumber_texture_slots(value, texture_map)


def drop_external_images(gltf: dict) -> list[str]:
    """Remove the images of `gltf` (JSON, edited in place) whose URI is not a data: URI; return those URIs."""
    images = gltf.get("images")
    if not isinstance(images, list) or not any(_is_external(im) for im in images):
        return []
    dropped = [im["uri"] for im in images if _is_external(im)]
    image_map: dict[int, int | None] = {}
    for i, im in enumerate(images):
        image_map[i] = None if _is_external(im) else i - sum(_is_external(x) for x in images[:i])
    gltf["images"] = [im for im in images if not _is_external(im)]
    texture_map: dict[int, int | None] = {}
    kept_textures: list[dict] = []
    for t, texture in enumerate(gltf.get("textures", [])):
        if _renumber_images(texture, image_map):
            texture_map[t] = len(kept_textures)
            kept_textures.append(texture)
        else:
            texture_map[t] = None
    if "textures" in gltf:
        gltf["textures"] = kept_textures
    _renumber_texture_slots(gltf.get("materials", []), texture_map)
    for key in ("images", "textures"):
        if key in gltf and not gltf[key]:
            del gltf[key]
    return dropped
