"""Run by Blender's Python (bpy), never imported by RigForge: GLB → binary FBX 7.4 with Blender's own exporter.

Usage: python fbx_blender_script.py IN.glb OUT.fbx FPS
Imports the GLB with Blender's glTF importer (the scene's frame rate set first, so keys land on whole frames),
keeps the armature and the meshes it deforms (not the importer's bone-display shapes), and exports them with
io_scene_fbx: every frame baked (no key reduction), no leaf bones, textures embedded, Blender's default axes
(-Z forward, Y up) and units (centimetres in the file), as Unity and Unreal import them.
"""

import sys

import bpy


def main(src: str, dst: str, fps: int) -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = fps, 1.0
    bpy.ops.import_scene.gltf(filepath=src)
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
