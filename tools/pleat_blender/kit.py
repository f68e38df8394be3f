"""The Blender cloth simulation as a Pleat training kit: the garment's point cache (PC2, in the vertex order of
the exported garment), the garment OBJ and npz, the motion BVH read back from the armature, and the manifest
`pleat-train simsup --user-sim` reads — checked by pleat.train.pointcache like any user cache.

Files, in the scene's units with Z up (the manifest says which): garment.npz (written by setup_scene),
garment.obj (rest), garment_sim.pc2 (sample k at scene frame frame_start + k), motion.bvh, user_sim.json.
"""
import json
from pathlib import Path

import bpy
import numpy as np

from . import axes
from .scene import kit_settings, read_pose, unit_m


def evaluated_positions(obj, depsgraph):
    """The object's evaluated vertices [N, 3] in world coordinates (Blender units)."""
    mesh = obj.evaluated_get(depsgraph).data
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3).astype(np.float64)
    M = np.array(obj.matrix_world)
    return co @ M[:3, :3].T + M[:3, 3]


def simulate(scene, garment_obj, progress=None):
    """Runs the cloth modifier over the scene's frame range, frame by frame from the first (Blender steps cloth
    only forward one frame at a time) → positions [T, N, 3] in Blender units and axes."""
    out = []
    for f in range(scene.frame_start, scene.frame_end + 1):
        scene.frame_set(f)
        x = evaluated_positions(garment_obj, bpy.context.evaluated_depsgraph_get())
        if len(x) != len(garment_obj.data.vertices):
            raise RuntimeError(f"frame {f}: the cloth has {len(x)} vertices, the mesh {len(garment_obj.data.vertices)}"
                               ": a modifier after the cloth changes the topology")
        out.append(x)
        if progress:
            progress(f)
    return np.array(out)


def kit_clip(scene):
    """The armature's action over the scene's frames as a Pleat Clip (the split of pleat.motion.bvh_export)."""
    from pleat.sim.scene import load_body
    rec = kit_settings(scene)
    body = load_body(rec["body"])
    arm = bpy.data.objects[rec["objects"]["armature"]]
    frames = np.arange(scene.frame_start, scene.frame_end + 1)
    q, loc = read_pose(arm, body, frames)
    fps = scene.render.fps / scene.render.fps_base
    return axes.pose_clip(q, loc, body, fps, rec["beta"], unit_m(scene), name=rec["motion"].split("/")[-1]), body


def export_kit(scene, positions=None, validate=True):
    """Simulates (unless `positions` are given) and writes the kit into the scene's kit folder. Returns
    {"kit_dir", "manifest", "positions" (Blender units), "check": pleat.train.pointcache's info or why not run}."""
    from pleat import fileio
    from pleat.garment import Garment
    from pleat.garment.meshio import write_obj
    from pleat.motion.bvh_export import write_bvh
    from pleat.train.pointcache import write_pc2
    rec = kit_settings(scene)
    if rec is None:
        raise ValueError("this scene was not made by Pleat's scene setup (no scene['pleat_kit'])")
    kit = Path(rec["kit_dir"])
    unit = unit_m(scene)
    garment_obj = bpy.data.objects[rec["objects"]["garment"]]
    fps = scene.render.fps / scene.render.fps_base
    if abs(fps - rec["fps"]) > 1e-6:
        raise ValueError(f"the scene plays at {fps:g} fps; it was set up at {rec['fps']:g} (the motion's rate)")
    if positions is None:
        positions = simulate(scene, garment_obj)
    g = Garment.load(kit / rec["garment_npz"])
    if positions.shape[1] != g.num_vertices:
        raise ValueError(f"the cache has {positions.shape[1]} points; the garment {g.num_vertices} vertices")
    write_pc2(kit / "garment_sim.pc2", positions.astype(np.float32), float(scene.frame_start), 1.0)
    write_obj(kit / "garment.obj", axes.to_blender(g.shaped(rec["beta"]), unit), g.faces,
              header=f"garment {g.name} at rest, {g.num_vertices} vertices in the garment's order")
    clip, body = kit_clip(scene)
    write_bvh(kit / "motion.bvh", clip, body, units="cm" if unit != 1.0 else "m")
    manifest = {"simulations": [{
        "name": f"{g.name}_blender", "cache": "garment_sim.pc2", "motion": "motion.bvh", "garment_obj": "garment.obj",
        "units": axes.units_label(unit), "up": "z", "beta": rec["beta"], "motion_start_frame": scene.frame_start,
        "skip_frames": rec["lead_in"]}]}
    fileio.write_text(kit / "user_sim.json", json.dumps(manifest, indent=1) + "\n")
    check = validate_kit(kit) if validate else "not checked"
    return {"kit_dir": str(kit), "manifest": kit / "user_sim.json", "positions": positions, "check": check}


def validate_kit(kit, preset="tiny"):
    """pleat.train.pointcache's checks on the kit (the ones `pleat-train simsup --user-sim` runs first): the info
    dict, or a sentence saying why they could not run here (they need PyTorch, which Blender's own Python lacks;
    pleat-train runs them anyway before it trains). A bad kit raises pleat.cli.InputError, one line."""
    try:
        from pleat.train import core, pointcache
    except ImportError as exc:
        return f"not checked here ({exc}); pleat-train checks the kit before training"
    kit = Path(kit)
    cfg = core.load_config(preset, None, {})
    setup = core.Setup(cfg, str(kit / "garment.npz"), "cpu")
    sim = pointcache.parse_user_sims([str(kit / "user_sim.json")])[0]
    _, info = pointcache.load_user_sim(setup, sim, cfg["fps"])
    return info
