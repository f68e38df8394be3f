"""The artist's scene: Pleat's body skinned to an armature with the body's skeleton, the clip as the armature's
action, and the garment as a cloth object pinned through a vertex group — everything a Blender cloth simulation of
the garment needs, in Blender's axes and units (pleat_blender.axes).

The scene remembers what it was made from (scene["pleat_kit"], JSON): the kit folder, which holds the garment npz
from the start; pleat_blender.kit writes the rest of the training kit there after the simulation.
"""
import json
from pathlib import Path

import bpy
import numpy as np

from . import axes
from .cloth import BODY_COLLISION, CLOTH

KIT_PROPERTY = "pleat_kit"
COLLECTION = "Pleat"
PIN_GROUP = "pleat_pins"
ARMATURE, BODY, GARMENT = "PleatArmature", "PleatBody", "PleatGarment"


def unit_m(scene):
    """Metres per Blender unit in this scene."""
    return float(scene.unit_settings.scale_length)


def kit_settings(scene):
    """The scene's kit description (setup_scene's record), or None for a scene not made by setup_scene."""
    text = scene.get(KIT_PROPERTY)
    return None if text is None else json.loads(text)


def _collection(scene):
    coll = bpy.data.collections.get(COLLECTION)
    if coll is None:
        coll = bpy.data.collections.new(COLLECTION)
    if coll.name not in scene.collection.children:
        scene.collection.children.link(coll)
    return coll


def _replace_object(coll, name, data):
    """A fresh object `name` in `coll` (an older one of that name, from an earlier setup, is removed first)."""
    old = bpy.data.objects.get(name)
    if old is not None:
        bpy.data.objects.remove(old, do_unlink=True)
    obj = bpy.data.objects.new(name, data)
    coll.objects.link(obj)
    return obj


def mesh_from_arrays(name, vertices, faces):
    """A Blender mesh with exactly these vertices in this order (from_pydata keeps the order, which a point cache
    depends on; an OBJ import may not)."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(np.asarray(vertices, np.float64).tolist(), [], np.asarray(faces, np.int64).tolist())
    mesh.validate(clean_customdata=False)
    mesh.update()
    if len(mesh.vertices) != len(vertices):
        raise RuntimeError(f"{name}: Blender kept {len(mesh.vertices)} of {len(vertices)} vertices")
    return mesh


def _skin_groups(obj, joint_names, indices, weights):
    """One vertex group per joint (named as the joint, as Blender's Armature modifier expects) from per-vertex
    influences [N, K]."""
    indices, weights = np.asarray(indices), np.asarray(weights, np.float64)
    groups = {}
    for n in range(indices.shape[0]):
        for k in range(indices.shape[1]):
            w = float(weights[n, k])
            if w <= 0.0:
                continue
            j = int(indices[n, k])
            g = groups.get(j)
            if g is None:
                g = groups[j] = obj.vertex_groups.new(name=joint_names[j])
            g.add([n], w, 'REPLACE')


def _armature_modifier(obj, armature):
    mod = obj.modifiers.new("Armature", 'ARMATURE')
    mod.object = armature
    mod.use_vertex_groups = True
    mod.use_bone_envelopes = False
    mod.use_deform_preserve_volume = False       # linear blend skinning, as Pleat's body and garment are skinned
    obj.parent = armature
    return mod


def make_armature(scene, coll, body, beta, unit):
    """An armature with the body's skeleton at J(β): bones at the joints, pointing along +Z, roll 0 (axes.py)."""
    data = bpy.data.armatures.new(ARMATURE)
    arm = _replace_object(coll, ARMATURE, data)
    joints = axes.to_blender(body.joints(beta), unit)
    view_layer = bpy.context.view_layer
    previous = view_layer.objects.active
    view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode='EDIT')
    bones = []
    for k, name in enumerate(body.joint_names):
        b = data.edit_bones.new(name)
        b.head = joints[k]
        b.tail = joints[k] + np.array([0.0, 0.0, axes.BONE_LENGTH_M / unit])
        b.roll = 0.0
        if k:
            b.parent = bones[int(body.parents[k])]
        bones.append(b)
    bpy.ops.object.mode_set(mode='OBJECT')
    view_layer.objects.active = previous
    for pb in arm.pose.bones:
        pb.rotation_mode = 'QUATERNION'
    return arm


def set_action(arm, clip, body, beta, unit, start_frame):
    """The clip as the armature's action: one key per frame (linear, so that scrubbing between frames does not
    overshoot), frame i at scene frame start_frame + i."""
    quats, loc = axes.clip_pose(clip, body, beta, unit)
    T = clip.num_frames
    frames = start_frame + np.arange(T, dtype=np.float64)
    action = bpy.data.actions.new(f"Pleat {clip.name}")

    def curve(path, index, group, values):
        fc = action.fcurves.new(path, index=index, action_group=group)
        fc.keyframe_points.add(T)
        fc.keyframe_points.foreach_set("co", np.stack([frames, values], 1).ravel())
        for kp in fc.keyframe_points:
            kp.interpolation = 'LINEAR'
        fc.update()

    for k, name in enumerate(body.joint_names):
        for i in range(4):
            curve(f'pose.bones["{name}"].rotation_quaternion', i, name, quats[:, k, i])
    root = body.joint_names[0]
    for i in range(3):
        curve(f'pose.bones["{root}"].location', i, root, loc[:, i])
    arm.animation_data_create()
    arm.animation_data.action = action
    return action


def read_pose(arm, body, frames):
    """The armature's action at scene `frames` → (bone quaternions [T, J, 4] (w, x, y, z), root location [T, 3]) —
    read from the action's curves, so it is the pose any frame evaluates to, edited keys included."""
    action = arm.animation_data.action if arm.animation_data else None
    frames = np.asarray(frames, np.float64)
    q = np.zeros((len(frames), len(body.joint_names), 4))
    q[..., 0] = 1.0
    loc = np.zeros((len(frames), 3))
    if action is None:
        return q, loc
    index = {name: k for k, name in enumerate(body.joint_names)}
    root = body.joint_names[0]
    for fc in action.fcurves:
        path = fc.data_path
        if not path.startswith('pose.bones["'):
            continue
        name = path[len('pose.bones["'):path.index('"]')]
        if name not in index:
            continue
        values = np.array([fc.evaluate(f) for f in frames])
        if path.endswith("rotation_quaternion"):
            q[:, index[name], fc.array_index] = values
        elif path.endswith("location") and name == root:
            loc[:, fc.array_index] = values
    return q, loc


def make_body(coll, arm, body, beta, unit):
    """The body mesh, skinned to the armature (LBS with the body's own weights) and a collision object."""
    obj = _replace_object(coll, BODY, mesh_from_arrays(BODY, axes.to_blender(body.shaped_vertices(beta), unit),
                                                        body.faces))
    w = np.asarray(body.weights)
    # every influence, not the 4 largest: the body's weights are dense, and cutting them moves vertices by mm
    K = int((w > 0).sum(1).max())
    idx = np.argsort(-w, axis=1)[:, :K]
    _skin_groups(obj, body.joint_names, idx, np.take_along_axis(w, idx, 1))
    _armature_modifier(obj, arm)
    col = obj.modifiers.new("Collision", 'COLLISION')      # noqa: F841 (the modifier makes obj.collision)
    obj.collision.thickness_outer = BODY_COLLISION["thickness_outer_m"] / unit
    obj.collision.thickness_inner = BODY_COLLISION["thickness_inner_m"] / unit
    obj.collision.cloth_friction = BODY_COLLISION["cloth_friction"]
    return obj


def make_garment_object(coll, arm, garment, body, beta, unit):
    """The cloth object: the garment in its own vertex order, skinned to the armature (so that it starts on the
    posed body and pinned vertices follow the body by LBS, as Pleat pins them), pins in PIN_GROUP, then the Cloth
    modifier with defaults for a light shirt. The artist tunes the cloth as usual."""
    obj = _replace_object(coll, GARMENT, mesh_from_arrays(GARMENT, axes.to_blender(garment.shaped(beta), unit),
                                                           garment.faces))
    _skin_groups(obj, body.joint_names, garment.skin_indices, garment.skin_weights)
    pins = obj.vertex_groups.new(name=PIN_GROUP)
    if len(garment.pinned):
        pins.add([int(i) for i in garment.pinned], 1.0, 'REPLACE')
    _armature_modifier(obj, arm)
    cloth = obj.modifiers.new("Cloth", 'CLOTH')
    s = cloth.settings
    area = float(np.sum(garment.vertex_area))
    s.mass = 0.20022 * area / garment.num_vertices / 1.0     # kg per vertex at Pleat's default areal density
    for key in ("quality", "air_damping", "tension_stiffness", "compression_stiffness", "shear_stiffness",
                "bending_stiffness"):
        setattr(s, key, CLOTH[key])
    s.vertex_group_mass = PIN_GROUP                          # the cloth's pin group
    c = cloth.collision_settings
    c.distance_min = CLOTH["collision_distance_m"] / unit
    c.use_self_collision = CLOTH["self_collision"]
    return obj


def load_garment(body, garment, vertices=None, mesh_object=None, pin_group=None, pins="auto", fit_mm=None,
                 units="m", up="y", work_dir=None, unit=1.0):
    """The garment as a pleat.garment.Garment, from: a procedural name (`vertices` about that many), a garment npz,
    a mesh file (OBJ / glTF, through pleat.garment.importer), or a Blender mesh object (`mesh_object`, with the
    vertices of vertex group `pin_group` pinned; written as OBJ and imported the same way)."""
    from pleat import fileio
    from pleat.garment import make_garment
    from pleat.garment.generate import GARMENT_NAMES
    from pleat.garment.importer import import_garment
    from pleat.sim.scene import load_garment_spec
    if mesh_object is not None:
        from pleat.garment.meshio import write_obj
        work_dir = Path(work_dir)
        work_dir.mkdir(parents=True, exist_ok=True)
        mesh = mesh_object.data
        x = np.array([mesh_object.matrix_world @ v.co for v in mesh.vertices], np.float64)
        tris = np.array([tuple(p.vertices) for p in mesh.polygons if len(p.vertices) == 3], np.int64)
        if len(tris) != len(mesh.polygons):
            raise ValueError(f"{mesh_object.name}: triangulate the mesh first (Pleat garments are triangle meshes)")
        path = work_dir / f"{mesh_object.name}.obj"
        write_obj(path, x, tris, header=f"Blender object {mesh_object.name}")
        pin_arg = "auto" if pins == "auto" and pin_group is None else pins
        if pin_group is not None:
            g = mesh_object.vertex_groups.get(pin_group)
            if g is None:
                raise ValueError(f"{mesh_object.name} has no vertex group {pin_group!r}")
            chosen = [v.index for v in mesh.vertices for e in v.groups if e.group == g.index and e.weight >= 0.5]
            pin_arg = str(work_dir / f"{mesh_object.name}_pins.json")
            fileio.write_text(pin_arg, json.dumps({"pins": chosen}))
        g, report, vmap, _ = import_garment(path, body, units=axes.units_label(unit), up="z", fit_mm=fit_mm,
                                            pins=pin_arg, name=mesh_object.name)
        return g, report
    spec = str(garment)
    if spec in GARMENT_NAMES and vertices:
        return make_garment(spec, vertices=int(vertices), body=body), None
    if Path(spec).suffix.lower() in (".obj", ".gltf", ".glb"):
        g, report, _, _ = import_garment(spec, body, units=units, up=up, fit_mm=fit_mm, pins=pins,
                                         pin_group=pin_group)
        return g, report
    return load_garment_spec(spec, body), None


def kit_motion(body, motion, frames=None, fps=30.0, lead_in=True):
    """The clip to simulate: any clip name or motion file the loaders take (pleat.train.pointcache.load_motion, as
    `pleat-garment scene` reads it), at `fps`, its first `frames` frames, after the reference simulator's lead-in
    from the rest pose (so the cloth starts unstrained). Returns (clip, lead-in frames)."""
    from pleat.garment.scene import kit_clip
    from pleat.train.pointcache import load_motion
    clip = load_motion(motion, body)
    if abs(clip.fps - fps) > 1e-6:
        clip = clip.resample(fps)
    if frames:
        clip = clip.frames_at(slice(0, int(frames)))
    return kit_clip(clip) if lead_in else (clip, 0)


def setup_scene(scene, kit_dir, garment="tshirt", motion="deepmimic_pybullet/humanoid3d_walk", frames=None,
                fps=30.0, vertices=None, mesh_object=None, pin_group=None, pins="auto", fit_mm=None, units="m",
                up="y", beta=None, start_frame=1, lead_in=True, body_path=None):
    """Builds the scene (armature + action, skinned collision body, cloth garment) and writes the garment npz to
    `kit_dir`. Returns {"armature", "body", "garment": objects, "lead_in": frames, "report": the import report}."""
    from pleat.sim.scene import load_body
    kit_dir = Path(bpy.path.abspath(str(kit_dir)))
    kit_dir.mkdir(parents=True, exist_ok=True)
    unit = unit_m(scene)
    body = load_body(body_path)
    b = np.zeros(body.num_betas)
    if beta is not None:
        b[:len(beta)] = beta
    g, report = load_garment(body, garment, vertices, mesh_object, pin_group, pins, fit_mm, units, up,
                             kit_dir / "source", unit)
    clip, lead = kit_motion(body, motion, frames, fps, lead_in)
    g.save(kit_dir / "garment.npz")
    scene.render.fps, scene.render.fps_base = int(round(fps)), 1.0
    if abs(scene.render.fps - fps) > 1e-6:
        scene.render.fps_base = scene.render.fps / fps
    scene.frame_start = int(start_frame)
    scene.frame_end = int(start_frame) + clip.num_frames - 1
    coll = _collection(scene)
    arm = make_armature(scene, coll, body, b, unit)
    set_action(arm, clip, body, b, unit, int(start_frame))
    body_obj = make_body(coll, arm, body, b, unit)
    garment_obj = make_garment_object(coll, arm, g, body, b, unit)
    cloth = garment_obj.modifiers["Cloth"]
    cloth.point_cache.frame_start = scene.frame_start
    cloth.point_cache.frame_end = scene.frame_end
    if mesh_object is not None:
        mesh_object.hide_set(True)
        mesh_object.hide_render = True
    record = {"kit_dir": str(kit_dir), "garment": g.name, "garment_npz": "garment.npz", "beta": b.tolist(),
              "fps": float(fps), "start_frame": int(start_frame), "lead_in": int(lead), "frames": clip.num_frames,
              "motion": str(motion), "body": body_path, "unit_m": unit, "pinned": int(len(g.pinned)),
              "objects": {"armature": arm.name, "body": body_obj.name, "garment": garment_obj.name}}
    scene[KIT_PROPERTY] = json.dumps(record)
    scene.frame_set(scene.frame_start)
    return {"armature": arm, "body": body_obj, "garment": garment_obj, "lead_in": lead, "report": report,
            "record": record}
