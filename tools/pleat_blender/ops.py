"""The add-on's user interface: preferences, scene settings, operators and the sidebar panel. Each operator is a
thin wrapper over pleat_blender.scene / kit / preview, which do the work (and which the tests call directly)."""
import sys

import bpy
from bpy.props import (EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty)

GARMENT_SOURCES = [("PROCEDURAL", "Procedural", "One of Pleat's garments, made on the body"),
                   ("FILE", "Mesh file", "An OBJ or glTF garment modelled on the Pleat body (pleat-garment import)"),
                   ("OBJECT", "Object", "A triangle mesh of this scene, modelled on the body; a vertex group pins")]
GARMENT_NAMES = [(n, n.replace("_", " "), "") for n in ("tshirt", "tank_top", "long_sleeve", "pants", "dress")]


def _addon_key():
    # "pleat_blender" as a legacy add-on, "bl_ext.<repository>.pleat" as an extension
    return __package__


class PleatPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    tools_path: StringProperty(
        name="Pleat tools", subtype='DIR_PATH',
        description="Folder that holds the pleat package (the repository's tools/, or a site-packages folder of a "
                    "Python 3.11 environment with pleat-tools installed); added to Python's path")

    def draw(self, context):
        self.layout.prop(self, "tools_path")


def _ensure_pleat(context):
    """Makes `import pleat` work: the preference's folder goes on sys.path. Returns an error sentence or None."""
    prefs = context.preferences.addons.get(_addon_key())
    path = prefs.preferences.tools_path if prefs is not None else ""
    if path and bpy.path.abspath(path) not in sys.path:
        sys.path.append(bpy.path.abspath(path))
    try:
        import pleat  # noqa: F401
    except ImportError as exc:
        return f"the pleat tools are not importable ({exc}): set the add-on preference 'Pleat tools'"
    return None


class PleatSettings(bpy.types.PropertyGroup):
    garment_source: EnumProperty(name="Garment", items=GARMENT_SOURCES, default="PROCEDURAL")
    garment_name: EnumProperty(name="Garment", items=GARMENT_NAMES, default="tshirt")
    vertices: IntProperty(name="Vertices", default=1000, min=300, max=20000,
                          description="About this many vertices for a procedural garment")
    garment_file: StringProperty(name="Mesh file", subtype='FILE_PATH')
    file_units: StringProperty(name="Units", default="m", description="m, cm, mm, in, or metres per unit")
    file_up: EnumProperty(name="Up", items=[("y", "Y", ""), ("z", "Z", "")], default="y")
    garment_object: PointerProperty(name="Object", type=bpy.types.Object,
                                    poll=lambda self, obj: obj.type == 'MESH')
    pin_group: StringProperty(name="Pin group", default="",
                              description="Vertex group of the object whose vertices follow the body (empty: "
                                          "Pleat's rule, the waistband of pants and skirts)")
    motion: StringProperty(name="Motion", default="deepmimic_pybullet/humanoid3d_walk",
                           description="A clip name (pleat-motion list) or a motion file (BVH, glTF, ASF/AMC)")
    frames: IntProperty(name="Frames", default=90, min=2, description="Motion frames after the 20-frame lead-in")
    fps: FloatProperty(name="FPS", default=30.0, min=1.0, max=240.0)
    kit_dir: StringProperty(name="Kit folder", subtype='DIR_PATH', default="//pleat_kit/")
    asset: StringProperty(name="Asset", subtype='FILE_PATH', description="A trained .pleat asset")


class PLEAT_OT_setup_scene(bpy.types.Operator):
    """Body, armature with the clip, and the garment as cloth"""
    bl_idname = "pleat.setup_scene"
    bl_label = "Set Up Scene"
    bl_options = {'REGISTER', 'UNDO'}

    def execute(self, context):
        error = _ensure_pleat(context)
        if error:
            self.report({'ERROR'}, error)
            return {'CANCELLED'}
        from pleat.cli import InputError
        from . import scene as pscene
        s = context.scene.pleat
        kw = dict(motion=s.motion, frames=s.frames, fps=s.fps)
        if s.garment_source == "PROCEDURAL":
            kw.update(garment=s.garment_name, vertices=s.vertices)
        elif s.garment_source == "FILE":
            kw.update(garment=bpy.path.abspath(s.garment_file), units=s.file_units, up=s.file_up)
        else:
            if s.garment_object is None:
                self.report({'ERROR'}, "choose the garment object")
                return {'CANCELLED'}
            kw.update(mesh_object=s.garment_object, pin_group=s.pin_group or None)
        try:
            made = pscene.setup_scene(context.scene, bpy.path.abspath(s.kit_dir), **kw)
        except (InputError, ValueError, OSError) as exc:
            self.report({'ERROR'}, str(exc))
            return {'CANCELLED'}
        rec = made["record"]
        self.report({'INFO'}, f"Pleat: {rec['garment']} ({rec['pinned']} pinned vertices) on {rec['frames']} "
                              f"frames at {rec['fps']:g} fps; kit folder {rec['kit_dir']}")
        return {'FINISHED'}


class PLEAT_OT_export_kit(bpy.types.Operator):
    """Simulate the cloth over the scene's frames and write the Pleat training kit"""
    bl_idname = "pleat.export_kit"
    bl_label = "Simulate and Export Kit"

    def execute(self, context):
        error = _ensure_pleat(context)
        if error:
            self.report({'ERROR'}, error)
            return {'CANCELLED'}
        from pleat.cli import InputError
        from . import kit
        wm = context.window_manager
        scene = context.scene
        wm.progress_begin(scene.frame_start, scene.frame_end)
        try:
            garment = bpy.data.objects[kit.kit_settings(scene)["objects"]["garment"]]
            positions = kit.simulate(scene, garment, progress=wm.progress_update)
            out = kit.export_kit(scene, positions)
        except (InputError, ValueError, KeyError, TypeError, OSError) as exc:
            self.report({'ERROR'}, str(exc))
            return {'CANCELLED'}
        finally:
            wm.progress_end()
        check = out["check"]
        said = (f"{check['frames']} frames, {check['mean_from_lbs_mm']:.1f} mm from LBS-only on average"
                if isinstance(check, dict) else check)
        self.report({'INFO'}, f"Pleat kit: {out['manifest']} ({said})")
        return {'FINISHED'}


class PLEAT_OT_load_preview(bpy.types.Operator):
    """Load a trained .pleat and preview it on the armature, stepped by the C runtime"""
    bl_idname = "pleat.load_preview"
    bl_label = "Preview Asset"

    def execute(self, context):
        error = _ensure_pleat(context)
        if error:
            self.report({'ERROR'}, error)
            return {'CANCELLED'}
        from . import preview
        try:
            preview.load_preview(context.scene, bpy.path.abspath(context.scene.pleat.asset))
        except (ValueError, OSError, RuntimeError, KeyError) as exc:
            self.report({'ERROR'}, str(exc))
            return {'CANCELLED'}
        return {'FINISHED'}


class PLEAT_OT_clear_preview(bpy.types.Operator):
    """Stop the preview (the runtime's objects are freed; the meshes stay)"""
    bl_idname = "pleat.clear_preview"
    bl_label = "Stop Preview"

    def execute(self, context):
        from . import preview
        preview.clear_previews()
        return {'FINISHED'}


class PLEAT_PT_panel(bpy.types.Panel):
    bl_label = "Pleat"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "Pleat"

    def draw(self, context):
        s = context.scene.pleat
        col = self.layout.column()
        col.label(text="1. Scene")
        col.prop(s, "garment_source", text="")
        if s.garment_source == "PROCEDURAL":
            col.prop(s, "garment_name")
            col.prop(s, "vertices")
        elif s.garment_source == "FILE":
            col.prop(s, "garment_file")
            row = col.row()
            row.prop(s, "file_units")
            row.prop(s, "file_up")
        else:
            col.prop(s, "garment_object")
            if s.garment_object is not None:
                col.prop_search(s, "pin_group", s.garment_object, "vertex_groups")
        col.prop(s, "motion")
        row = col.row()
        row.prop(s, "frames")
        row.prop(s, "fps")
        col.prop(s, "kit_dir")
        col.operator(PLEAT_OT_setup_scene.bl_idname)
        col.separator()
        col.label(text="2. Cloth (tune the PleatGarment's Cloth modifier)")
        col.operator(PLEAT_OT_export_kit.bl_idname)
        col.separator()
        col.label(text="3. Preview")
        col.prop(s, "asset")
        row = col.row()
        row.operator(PLEAT_OT_load_preview.bl_idname)
        row.operator(PLEAT_OT_clear_preview.bl_idname)


CLASSES = (PleatPreferences, PleatSettings, PLEAT_OT_setup_scene, PLEAT_OT_export_kit, PLEAT_OT_load_preview,
           PLEAT_OT_clear_preview, PLEAT_PT_panel)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.pleat = PointerProperty(type=PleatSettings)
    from . import preview
    preview.install_handler()


def unregister():
    from . import preview
    preview.remove_handler()
    preview.clear_previews()
    del bpy.types.Scene.pleat
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
