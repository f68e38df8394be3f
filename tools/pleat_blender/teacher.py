"""Blender's cloth as the teacher: the simulation pleat.eval.reference caches, made by Blender's Cloth modifier
instead of Pleat's own simulator, so that a model can be trained on it (`pleat-train simsup --set
'simsup.teacher="blender"'`) and scored against it (`pleat-eval --reference blender`, `pleat-eval-suite --reference
blender`).

The scene is the artist's (pleat_blender.scene, in metres): the body skinned to an armature playing the clip after
the reference simulator's lead-in from the rest pose, a Collision modifier on it (without the body parts the garment
does not collide with, Garment.collision_exclude), and the garment as a Cloth object with the add-on's light-shirt
settings, its pins following the body by skinning. Each call starts from an empty scene, so calls are independent (a
worker process can run many). There is no material argument: Blender's cloth is the add-on's one light shirt
(docs/accuracy.md, "A second teacher").

Needs `bpy` (the `blender` extra: Blender 4.4 as a Python module, Python 3.11).
"""
import time

import numpy as np

TEACHER = "blender"


def available():
    """None when bpy is installed here, else the sentence saying why Blender cannot be the teacher. Looks without
    importing: the caller may fork simulation workers afterwards, and each should start its own Blender."""
    from importlib.util import find_spec
    if find_spec("bpy") is None:
        return "Blender's cloth needs bpy (pip install -e 'tools[blender]', Python 3.11), which is not installed"
    return None


def _perturb(mesh, garment, perturbation_m, unit):
    """Moves every free vertex of the cloth's start as the reference simulator moves its start for the spread
    (pleat.sim.scene.start_perturbation): a second, equally valid simulation."""
    from pleat.sim.scene import start_perturbation
    from . import axes
    n = len(mesh.vertices)
    pinned = np.zeros(n, bool)
    pinned[np.asarray(garment.pinned, np.int64)] = True
    d = axes.to_blender(start_perturbation(n, pinned, perturbation_m), unit)
    co = np.empty(n * 3, np.float64)
    mesh.vertices.foreach_get("co", co)
    mesh.vertices.foreach_set("co", (co.reshape(-1, 3) + d).ravel())
    mesh.update()


def _keep_colliding(body_obj, mask):
    """Deletes the body vertices the garment does not collide with (Garment.collision_exclude: the dress passes
    through the forearms and hands, as in Pleat's simulator) from the collision body; mask None keeps them all."""
    if mask is None:
        return
    import bmesh
    bm = bmesh.new()
    bm.from_mesh(body_obj.data)
    bm.verts.ensure_lookup_table()
    bmesh.ops.delete(bm, geom=[bm.verts[int(i)] for i in np.flatnonzero(~np.asarray(mask))], context='VERTS')
    bm.to_mesh(body_obj.data)
    bm.free()
    body_obj.data.update()


def simulate(garment, body, clip, beta=None, frames=None, start_perturbation_m=0.0, progress=False):
    """Blender's cloth on `clip` (its first `frames` frames, after the lead-in) → (positions [T, N, 3] f32 in Pleat
    axes and metres, summary dict). Frame t is the cloth at the clip's frame t, as pleat.sim.scene.simulate's."""
    import bpy

    from pleat.garment.scene import kit_clip
    from pleat.train.simdata import cut
    from . import axes, kit
    from . import scene as S
    T = clip.num_frames if frames is None else min(int(frames), clip.num_frames)
    full, lead = kit_clip(cut(clip, 0, T))
    beta = np.zeros(body.num_betas) if beta is None else np.asarray(beta, np.float64)
    b = np.zeros(body.num_betas)
    b[:len(beta)] = beta[:body.num_betas]

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    unit = S.unit_m(scene)
    fps = float(clip.fps)
    scene.render.fps, scene.render.fps_base = int(round(fps)), 1.0
    if abs(scene.render.fps - fps) > 1e-6:
        scene.render.fps_base = scene.render.fps / fps
    scene.frame_start, scene.frame_end = 1, full.num_frames
    coll = S._collection(scene)
    arm = S.make_armature(scene, coll, body, b, unit)
    S.set_action(arm, full, body, b, unit, 1)
    _keep_colliding(S.make_body(coll, arm, body, b, unit), garment.body_collision_mask(body))
    obj = S.make_garment_object(coll, arm, garment, body, b, unit)
    if start_perturbation_m:
        _perturb(obj.data, garment, start_perturbation_m, unit)
    cache = obj.modifiers["Cloth"].point_cache
    cache.frame_start, cache.frame_end = scene.frame_start, scene.frame_end
    t0, c0 = time.perf_counter(), time.process_time()
    positions = kit.simulate(scene, obj)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    x = axes.to_pleat(positions[lead:lead + T], unit).astype(np.float32)
    if not np.isfinite(x).all():
        raise FloatingPointError(f"Blender's cloth produced non-finite positions on {clip.name}")
    n = full.num_frames
    summary = dict(teacher=TEACHER, blender=bpy.app.version_string, frames=int(T), lead_in_frames=int(lead),
                   seconds_per_frame=wall / n, cpu_seconds_per_frame=cpu / n, converged_fraction=1.0,
                   start_perturbation_m=float(start_perturbation_m))
    return x, summary
