"""Run by Blender's Python (bpy), never imported by RigForge: GLB → binary FBX 7.4 with Blender's own exporter.

Usage: python fbx_blender_script.py IN.glb OUT.fbx FPS UNITS UP
  UNITS: m | cm, the file's unit (GlobalSettings UnitScaleFactor 100 or 1).
  UP: y (Y up, the character facing +Z, glTF's own axes: FBX's Maya Y-up system) |
      z (Z up, facing -Y: FBX's Max/Maya Z-up system, Blender's own).
Imports the GLB with Blender's glTF importer (the scene's frame rate set first, so keys land on whole frames),
wires each material's base-colour image straight into its shader (io_scene_fbx misses it behind the importer's
colour-factor node), keeps the armature and the meshes it deforms (not the importer's bone shapes), turns and scales
them into the file's axes and unit and applies that to their data (bind pose, vertices, the clip's translations), and
exports with io_scene_fbx without a space transform: every root node is identity, so an engine shows the model with
no stray -90° turn or 100× scale. Every frame is baked (no key reduction), no leaf bones, textures embedded.
"""

import sys

import bpy
from bpy_extras.io_utils import axis_conversion
from mathutils import Matrix

AXES = {"y": ("Y", "-Z"), "z": ("Z", "Y")}  # io_scene_fbx's (up, forward) for each file frame
CENTIMETRES = {"m": 100.0, "cm": 1.0}  # UnitScaleFactor: centimetres per file unit


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


def location_curves():
    """Every translation f-curve of every action (Blender 5 keeps them in slotted layers' channelbags)."""
    for action in bpy.data.actions:
        for layer in action.layers:
            for strip in layer.strips:
                for bag in strip.channelbags:
                    yield from (curve for curve in bag.fcurves if curve.data_path.endswith(".location"))


def bake_file_frame(objects: list, up: str, units: str) -> None:
    """Turn and scale `objects` (Blender: Z up, metres) into the file's axes and unit, applied to their data.

    Bone translations are keyed in bone space, which the turn leaves alone but the scale does not: they are scaled."""
    if not objects:
        return
    scale = 100.0 / CENTIMETRES[units]
    axis_up, forward = AXES[up]
    conversion = axis_conversion(to_forward=forward, to_up=axis_up).to_4x4() @ Matrix.Scale(scale, 4)
    for obj in objects:
        if obj.parent is None:
            obj.matrix_world = conversion @ obj.matrix_world
    bpy.context.view_layer.update()
    bpy.ops.object.select_all(action="DESELECT")
    for obj in objects:
        obj.select_set(True)
    bpy.context.view_layer.objects.active = objects[0]
    bpy.ops.object.transform_apply(location=True, rotation=True, scale=True, isolate_users=True)
    for curve in location_curves():
        for key in curve.keyframe_points:
            key.co[1] *= scale
            key.handle_left[1] *= scale
            key.handle_right[1] *= scale


def main(src: str, dst: str, fps: int, units: str, up: str) -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = fps, 1.0
    bpy.ops.import_scene.gltf(filepath=src)
    link_textures_directly()
    armatures = [o for o in scene.objects if o.type == "ARMATURE"]
    skinned = [o for o in scene.objects if o.type == "MESH" and any(m.type == "ARMATURE" for m in o.modifiers)]
    bake_file_frame(armatures + skinned, up, units)
    scene.unit_settings.system = "METRIC"
    scene.unit_settings.scale_length = CENTIMETRES[units] / 100.0  # FBX_SCALE_UNITS writes 100 × this as the unit
    actions = list(bpy.data.actions)
    if actions:
        start, end = actions[0].frame_range
        scene.frame_start, scene.frame_end = int(round(start)), int(round(end))
    bpy.ops.export_scene.fbx(
        filepath=dst, use_selection=True, object_types={"ARMATURE", "MESH"}, add_leaf_bones=False,
        bake_anim=bool(actions), bake_anim_use_all_actions=False, bake_anim_use_nla_strips=False,
        bake_anim_simplify_factor=0.0, bake_anim_force_startend_keying=True, path_mode="COPY", embed_textures=True,
        axis_up=AXES[up][0], axis_forward=AXES[up][1], use_space_transform=False, apply_unit_scale=True,
        apply_scale_options="FBX_SCALE_UNITS",
    )


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4], sys.argv[5])
