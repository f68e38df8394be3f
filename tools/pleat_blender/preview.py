"""A trained `.pleat` asset previewed on the scene's armature, stepped by the C runtime (pleat.runtime) on every
frame change, with its LBS-only twin beside it and each one's per-vertex error against the Blender cloth cache as
colour attributes.

Frame f of the scene is runtime step f − frame_start from a reset at frame_start (the first frame of the kit, the
lead-in's rest pose). Playing forward steps once per frame with dt = 1 / fps; any other jump resets the instance
and replays from frame_start, so a frame always shows what the runtime would show after playing up to it.
"""
from pathlib import Path

import bpy
import numpy as np

from . import axes
from .scene import COLLECTION, _replace_object, kit_settings, mesh_from_arrays, read_pose, unit_m

PREVIEW, TWIN = "PleatPreview", "PleatLBS"
ERROR_COLOURS = "pleat_error"          # colour attribute (blue 0 → red ≥ 20 mm)
ERROR_MM = "pleat_error_mm"            # float attribute, the same error in millimetres
TWIN_OFFSET_M = 0.8                    # the LBS twin stands this far to the character's left (+X)

_previews = {}                          # preview object name → _Preview


class _Preview:
    """The runtime objects and playback state of one preview."""

    def __init__(self, scene, asset_path, cache=None, library=None):
        from pleat.asset import read_asset
        from pleat.runtime import Context
        from pleat.sim.scene import load_body
        rec = kit_settings(scene)
        if rec is None:
            raise ValueError("this scene was not made by Pleat's scene setup (no scene['pleat_kit'])")
        self.rec = rec
        self.body = load_body(rec["body"])
        self.arm_name = rec["objects"]["armature"]
        self.asset_path = str(asset_path)
        weights = read_asset(Path(asset_path).read_bytes())
        self.ctx = Context(library=library)
        self.asset = self.ctx.load_asset(str(asset_path))
        beta = np.asarray(rec["beta"], np.float32)[:self.asset.info["beta_count"]]
        self.instance = self.ctx.create_instance(self.asset, beta=beta)
        names = list(self.body.joint_names)
        missing = [n for n in self.asset.joint_names if n not in names]
        if missing:
            raise ValueError(f"{asset_path}: joints {missing} are not the body's")
        self.joint_index = np.array([names.index(n) for n in self.asset.joint_names])
        self.faces = np.asarray(weights["faces"], np.int64)
        b = np.zeros(weights["shape_blend"].shape[0])
        b[:len(beta)] = beta[:len(b)]
        self.shaped = np.asarray(weights["template"], np.float64) + np.einsum(
            "b,bnc->nc", b, np.asarray(weights["shape_blend"], np.float64))
        self.skin_indices = np.asarray(weights["skin_indices"], np.int64)
        self.skin_weights = np.asarray(weights["skin_weights"], np.float64)
        self.cache = cache                          # [T, N, 3] Blender units, sample k at scene frame start + k
        self.frame = None
        self.fps = rec["fps"]

    def close(self):
        for obj in (self.instance, self.asset, self.ctx):
            obj.close()

    def pose(self, frames):
        """Runtime inputs at scene `frames`: rotations [T, J_asset, 4] (x, y, z, w), root translation [T, 3],
        root rotation [T, 4] — the armature's action through axes.pose_clip."""
        arm = bpy.data.objects[self.arm_name]
        q, loc = read_pose(arm, self.body, frames)
        clip = axes.pose_clip(q, loc, self.body, self.fps, self.rec["beta"], unit_m(bpy.context.scene))
        return clip.local_rotations[:, self.joint_index], clip.root_translation, clip.root_rotation

    def go_to(self, frame):
        """Steps the runtime to scene `frame` → (Pleat positions [N, 3], LBS-only positions [N, 3]), metres."""
        start = self.rec["start_frame"]
        frame = max(int(frame), start)
        if self.frame is not None and frame == self.frame:
            return self.positions, self.lbs
        if self.frame is None or frame != self.frame + 1:
            self.instance.reset()
            todo = np.arange(start, frame + 1)
        else:
            todo = np.array([frame])
        rot, t, r = self.pose(todo)
        for i in range(len(todo)):
            # the first step after a reset has no previous frame; dt is the frame time all the same
            self.positions, _ = self.instance.step(rot[i], t[i], r[i], 1.0 / self.fps)
        M = self.instance.skin_matrices                                     # [J, 3, 4], this frame's LBS
        A = np.einsum("nk,nkij->nij", self.skin_weights, M[self.skin_indices].astype(np.float64))
        self.lbs = np.einsum("nij,nj->ni", A[:, :, :3], self.shaped) + A[:, :, 3]
        self.frame = frame
        return self.positions, self.lbs

    def cached(self, frame):
        """The Blender cache at scene `frame` in metres (Pleat axes), or None outside it."""
        if self.cache is None:
            return None
        k = int(frame) - self.rec["start_frame"]
        if not 0 <= k < len(self.cache):
            return None
        return axes.to_pleat(self.cache[k], unit_m(bpy.context.scene))


def _set_error(mesh, error_m):
    if ERROR_MM not in mesh.attributes:
        mesh.attributes.new(ERROR_MM, 'FLOAT', 'POINT')
    mesh.attributes[ERROR_MM].data.foreach_set("value", (1e3 * error_m).astype(np.float32))
    if ERROR_COLOURS not in mesh.color_attributes:
        mesh.color_attributes.new(ERROR_COLOURS, 'FLOAT_COLOR', 'POINT')
    mesh.color_attributes[ERROR_COLOURS].data.foreach_set("color", axes.error_colours(error_m).astype(np.float32)
                                                          .ravel())
    mesh.color_attributes.active_color = mesh.color_attributes[ERROR_COLOURS]


def _update(scene, state, frame):
    unit = unit_m(scene)
    pleat, lbs = state.go_to(frame)
    ref = state.cached(frame)
    for name, x in ((PREVIEW, pleat), (TWIN, lbs)):
        obj = bpy.data.objects.get(name)
        if obj is None:
            continue
        mesh = obj.data
        mesh.vertices.foreach_set("co", axes.to_blender(x, unit).astype(np.float32).ravel())
        err = np.zeros(len(x)) if ref is None else np.linalg.norm(np.asarray(x, np.float64) - ref, axis=1)
        _set_error(mesh, err)
        mesh.update()


@bpy.app.handlers.persistent
def on_frame_change(scene, depsgraph=None):
    """frame_change_post: every preview follows the scene's frame."""
    for state in list(_previews.values()):
        try:
            _update(scene, state, scene.frame_current)
        except (ReferenceError, KeyError):
            pass                                  # its objects were deleted: nothing to show


def install_handler():
    if on_frame_change not in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.append(on_frame_change)


def remove_handler():
    while on_frame_change in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.remove(on_frame_change)


def clear_previews():
    for state in _previews.values():
        state.close()
    _previews.clear()


def load_preview(scene, asset_path, library=None):
    """Loads the asset into the C runtime and adds the preview (PleatPreview) and its LBS-only twin (PleatLBS,
    TWIN_OFFSET_M to the side), both children of the armature; reads the kit's garment_sim.pc2, when it is there,
    for the error colours. Returns the preview state."""
    from pleat.train.pointcache import read_pc2
    rec = kit_settings(scene)
    if rec is None:
        raise ValueError("this scene was not made by Pleat's scene setup (no scene['pleat_kit'])")
    pc2 = Path(rec["kit_dir"]) / "garment_sim.pc2"
    cache = None
    if pc2.is_file():
        c = read_pc2(pc2)
        if c.start_frame == rec["start_frame"] and c.sample_rate == 1.0:
            cache = c.positions.astype(np.float64)
    clear_previews()
    state = _Preview(scene, asset_path, cache, library)
    if cache is not None and cache.shape[1] != len(state.shaped):
        state.cache = None                        # an asset of another garment: no error to show
    unit = unit_m(scene)
    arm = bpy.data.objects[state.arm_name]
    coll = bpy.data.collections.get(COLLECTION) or scene.collection
    for name, dx in ((PREVIEW, 0.0), (TWIN, TWIN_OFFSET_M)):
        obj = _replace_object(coll, name, mesh_from_arrays(name, axes.to_blender(state.shaped, unit), state.faces))
        obj.parent = arm
        obj.location = (dx / unit, 0.0, 0.0)
    _previews[PREVIEW] = state
    install_handler()
    _update(scene, state, scene.frame_current)
    return state
