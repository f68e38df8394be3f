"""The pictures of docs/blender.md, rendered by Blender (Workbench, headless) from the scene of
tests/python/test_blender_roundtrip.py: a 300-vertex t-shirt pinned at the collar, 6 frames of
humanoid3d_walk after the 20-frame lead-in, simulated by Blender's Cloth modifier, then a tiny asset trained on it
and previewed through the C runtime.

    PLEAT_BUILD_DIR=build/release .venv/bin/python scripts/blender-doc-images.py [--out docs/images] [--work DIR]

Needs the blender and train extras (bpy, PyTorch), the motion clips and libpleat.so.
"""
import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tools"))

CLIP = "deepmimic_pybullet/humanoid3d_walk"


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--out", default=str(REPO / "docs" / "images"))
    p.add_argument("--work", default=None)
    args = p.parse_args()
    import bpy
    from pleat.garment import make_garment
    from pleat.garment.importer import pick_pins
    from pleat.sim.scene import load_body
    from pleat_blender import axes, kit, preview
    from pleat_blender import scene as pscene
    work = Path(args.work or tempfile.mkdtemp(prefix="pleat_blender_"))
    out = Path(args.out)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    body = load_body()
    g = make_garment("tshirt", vertices=300, body=body)
    collar, _ = pick_pins("collar", g.template, g.faces, body)
    shirt = bpy.data.objects.new("ArtistShirt", pscene.mesh_from_arrays("ArtistShirt", axes.to_blender(g.template),
                                                                        g.faces))
    scene.collection.objects.link(shirt)
    shirt.vertex_groups.new(name="collar").add([int(i) for i in collar], 1.0, 'REPLACE')
    made = pscene.setup_scene(scene, work / "kit", motion=CLIP, frames=6, mesh_object=shirt, pin_group="collar")
    kit.export_kit(scene)
    run = subprocess.run([sys.executable, "-m", "pleat.train.cli", "simsup", "--preset", "tiny", "--garment",
                          str(work / "kit" / "garment.npz"), "--user-sim", str(work / "kit" / "user_sim.json"),
                          "--user-sim", f"cache={work / 'kit' / 'garment_sim.pc2'},motion={work / 'kit' / 'motion.bvh'}"
                          ",units=m,up=z,skip_frames=20,role=validation,name=blender_walk", "--user-sim-only",
                          "--out", str(work / "run"), "--cache-dir", str(work / "cache"), "--quiet"],
                         capture_output=True, text=True)
    if run.returncode:
        sys.exit(run.stderr)
    asset = next((work / "run").glob("*.pleat"))

    frame = scene.frame_end
    scene.frame_set(frame)
    made["armature"].hide_render = True
    made["body"].color = (0.62, 0.6, 0.58, 1.0)
    made["garment"].color = (0.25, 0.45, 0.75, 1.0)
    root = np.array(made["armature"].matrix_world @ made["armature"].pose.bones[0].head)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    cam.data.lens = 50
    r = scene.render
    r.engine = 'BLENDER_WORKBENCH'
    r.image_settings.file_format, r.image_settings.color_mode, r.image_settings.compression = 'PNG', 'RGB', 100
    shading = scene.display.shading
    shading.light, shading.show_cavity = 'STUDIO', False
    scene.world = bpy.data.worlds.new("World")

    def render(path, width, height):
        r.resolution_x, r.resolution_y, r.resolution_percentage = width, height, 100
        r.filepath = str(path)
        bpy.ops.render.render(write_still=True)
        print(f"wrote {path} ({path.stat().st_size // 1024} KB)")

    # 1. Blender's cloth on the skinned body: the kit's last frame
    shading.color_type = 'OBJECT'
    cam.location = (root[0] + 0.9, root[1] - 2.2, root[2] + 0.25)
    cam.rotation_euler = (np.radians(85), 0.0, np.radians(22))
    render(out / "blender_cloth.png", 480, 540)

    # 2. the preview: the asset through the C runtime on the body, the LBS-only twin beside it (a snapshot of the
    # body under it, for the picture), both coloured by their error against the cloth cache
    preview.load_preview(scene, asset)
    scene.frame_set(frame - 1)
    scene.frame_set(frame)
    made["garment"].hide_render = True
    posed = kit.evaluated_positions(made["body"], bpy.context.evaluated_depsgraph_get())
    twin_body = bpy.data.objects.new("BodyBeside", pscene.mesh_from_arrays(
        "BodyBeside", posed + np.array([preview.TWIN_OFFSET_M, 0.0, 0.0]), body.faces))
    scene.collection.objects.link(twin_body)
    shading.color_type = 'VERTEX'
    cam.location = (root[0] + 0.4 + 0.35, root[1] - 3.6, root[2] + 0.3)
    cam.rotation_euler = (np.radians(86), 0.0, np.radians(6))
    render(out / "blender_preview.png", 600, 420)
    preview.clear_previews()


if __name__ == "__main__":
    main()
