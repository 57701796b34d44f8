"""Run by Blender's Python (bpy), never imported by RigForge: GLB → binary FBX 7.4 with Blender's own exporter.

Usage: python fbx_blender_script.py IN.glb OUT.fbx FPS
Imports the GLB with Blender's glTF importer (the scene's frame rate set first, so keys land on whole frames),
wires each material's base-colour image straight into its shader (io_scene_fbx misses it behind the importer's
colour-factor node), keeps the armature and the meshes it deforms (not the importer's bone shapes), and exports with
io_scene_fbx: every frame baked (no key reduction), no leaf bones, textures embedded, Blender's default axes
(-Z forward, Y up) and units (centimetres in the file), as Unity and Unreal import them.
"""

import sys

import bpy


def link_textures_directly() -> None:
    """io_scene_fbx only finds an image texture wired straight into Base Color; the glTF importer puts a
    multiply node between them when the material has a colour factor. Wire the image straight in and keep the
    factor as the Base Color value (written as the FBX DiffuseColor)."""
    for material in bpy.data.materials:
        tree = material.node_tree
        bsdf = next((n for n in tree.nodes if n.type == "BSDF_PRINCIPLED"), None) if tree else None
        if bsdf is None or not bsdf.inputs["Base Color"].is_linked:
            continue
        mix = bsdf.inputs["Base Color"].links[0].from_node
        if mix.type != "MIX":
            continue
        sources = [i.links[0].from_node for i in mix.inputs if i.is_linked]
        image = next((node for node in sources if node.type == "TEX_IMAGE"), None)
        factor = next((i.default_value for i in mix.inputs if i.type == "RGBA" and not i.is_linked), None)
        if image is None:
            continue
        if factor is not None:
            bsdf.inputs["Base Color"].default_value = factor
        tree.links.new(image.outputs["Color"], bsdf.inputs["Base Color"])


def main(src: str, dst: str, fps: int) -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = fps, 1.0
    bpy.ops.import_scene.gltf(filepath=src)
    link_textures_directly()
    armatures = [o for o in scene.objects if o.type == "ARMATURE"]
    skinned = [o for o in scene.objects if o.type == "MESH" and any(m.type == "ARMATURE" for m in o.modifiers)]
    bpy.ops.object.select_all(action="DESELECT")
    for obj in armatures + skinned:
        obj.select_set(True)
    actions = list(bpy.data.actions)
    if actions:
        start, end = actions[0].frame_range
        scene.frame_start, scene.frame_end = int(round(start)), int(round(end))
    bpy.ops.export_scene.fbx(
        filepath=dst, use_selection=True, object_types={"ARMATURE", "MESH"}, add_leaf_bones=False,
        bake_anim=bool(actions), bake_anim_use_all_actions=False, bake_anim_use_nla_strips=False,
        bake_anim_simplify_factor=0.0, bake_anim_force_startend_keying=True, path_mode="COPY", embed_textures=True,
    )


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]))
