"""Pleat for Blender: the technical artist's loop inside Blender.

1. Set up: Pleat's body skinned to an armature with the body's skeleton, a clip as the armature's action, a garment
   (procedural, a mesh file, or your own mesh with a pin vertex group) as a cloth object (pleat_blender.scene).
2. Simulate with Blender's Cloth modifier, tuned as usual, and export a Pleat training kit — PC2 + OBJ + BVH + the
   manifest of `pleat-train simsup --user-sim`, checked by pleat.train.pointcache (pleat_blender.kit).
3. Preview a trained `.pleat` on the armature, stepped by the C runtime on each frame change, beside its LBS-only
   twin, both coloured by their error against the cloth cache (pleat_blender.preview).

Installable from a zip (`python -m pleat_blender.package`) as a legacy add-on (bl_info) or an extension
(blender_manifest.toml); importable as a module (`bpy` from PyPI). It needs the `pleat` tools package importable:
set the add-on preference "Pleat tools" to the folder that holds it (docs/blender.md).
"""
bl_info = {
    "name": "Pleat",
    "author": "The Pleat authors",
    "version": (0, 1, 0),
    "blender": (4, 4, 0),
    "location": "3D Viewport > Sidebar > Pleat",
    "description": "Cloth simulations as Pleat training kits, and trained Pleat assets previewed on the armature",
    "doc_url": "https://github.com/pleat/pleat/blob/main/docs/blender.md",
    "category": "Physics",
}


def register():
    from . import ops
    ops.register()


def unregister():
    from . import ops
    ops.unregister()
