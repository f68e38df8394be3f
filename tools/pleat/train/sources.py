"""Where training gets the body, garment, motion and energies from: pleat.body, pleat.garment, pleat.motion and
pleat.physics, nothing else. A missing module or body file is an error, never a silent substitute; clips of the split
that the motion folder lacks are left out with a warning (pleat.motion.split.available), and a split with none is an
error. `used` records what was read (paths, garment spec, loaders); it is written into the run config and the asset's
META.
"""
from pathlib import Path

import numpy as np

from pleat import REPO_ROOT

used = {}


def body(path="assets/body.npz"):
    from pleat.body import BodyModel
    p = Path(path)
    if not p.is_absolute():
        p = REPO_ROOT / p
    if not p.exists():
        raise FileNotFoundError(f"{p}: no body model (docs/body.md: fetch or build assets/body.npz)")
    used["body"] = str(p)
    return BodyModel.load(str(p))


def garment(spec, body_model, vertices):
    """An npz path (pleat-garment output) or a garment name generated at `vertices` vertices."""
    if str(spec).endswith(".npz"):
        with np.load(spec, allow_pickle=False) as data:
            used["garment"] = str(spec)
            return {k: data[k] for k in data.files}
    from pleat.garment import make_garment
    used["garment"] = f"pleat.garment.make_garment({spec!r}, vertices={vertices})"
    return make_garment(spec, vertices=vertices, body=body_model)


def field(obj, name, default=None):
    if isinstance(obj, dict):
        return obj.get(name, default)
    return getattr(obj, name, default)


_CLIP_CACHE = {}


def clips(split, fps, count_limit=None, frames_limit=None, body_model=None):
    """Training or validation clips resampled to `fps`: objects with fps, rotations [T,J,4] (x,y,z,w),
    root_translation [T,3], root_rotation [T,4]. Loaded (and retargeted) once per process: stage 1, its
    validation, stage 2 and the ablation all ask for the same clips."""
    body_key = None if body_model is None else float(np.asarray(body_model.v_template).sum())
    key = (split, float(fps), count_limit, body_key)
    if key not in _CLIP_CACHE:
        _CLIP_CACHE[key] = _load_clips(split, fps, count_limit, body_model)
    out = [_Clip(getattr(c, "name", "clip"), c.fps, c.rotations, c.root_translation, c.root_rotation) for c in _CLIP_CACHE[key]]
    if frames_limit:
        for c in out:
            c.rotations = c.rotations[:frames_limit]
            c.root_translation = c.root_translation[:frames_limit]
            c.root_rotation = c.root_rotation[:frames_limit]
    return out


def _load_clips(split, fps, count_limit, body_model):
    out = _motion_clips(split, fps, body_model, count_limit)
    used[f"motion_{split}"] = "pleat.motion"
    return out[:count_limit] if count_limit else out


class _Clip:
    def __init__(self, name, fps, rotations, root_translation, root_rotation):
        self.name, self.fps = name, fps
        self.rotations, self.root_translation, self.root_rotation = rotations, root_translation, root_rotation


def _motion_clips(split, fps, body_model=None, count_limit=None):
    from pleat.motion import load_clip, split as motion_split
    # the split's clips that are in the motion folder (one warning names the missing ones; none at all is an error)
    names = motion_split.available(split)
    names = names[:count_limit] if count_limit else names
    result = []
    for name in names:
        clip = load_clip(name, body=body_model).resample(fps)
        result.append(_Clip(clip.name, clip.fps, clip.local_rotations, clip.root_translation, clip.root_rotation))
    return result


class Energies:
    """Equation 4 terms for one garment from pleat.physics (torch path). material = (m kg/m², μ, λ, k)."""

    def __init__(self, template, faces, torch, friction_mu=0.5, friction_eps_m=1e-3, collision_eps_m=4e-3,
                 device=None):
        import pleat.physics as ph
        used["energies"] = "pleat.physics"
        self.ph, self.torch = ph, torch
        self.rest = ph.cloth_rest(template, faces)
        self._rest_t = None
        self.faces = torch.as_tensor(self.rest.faces, device=device)      # indexes the states on that device
        self.friction_mu, self.friction_eps, self.eps = friction_mu, friction_eps_m, collision_eps_m

    def __getstate__(self):
        # the modules are imported again where this is unpickled (a Ray task's process, pleat.train.tasks)
        return {k: v for k, v in self.__dict__.items() if k not in ("ph", "torch")}

    def __setstate__(self, state):
        import torch

        import pleat.physics as ph
        self.__dict__.update(state, ph=ph, torch=torch)

    def rest_for(self, shaped, like):
        """Rest geometry of the garment shaped for β (T + G_S(β)), as HOOD takes the garment's rest state: the
        β = 0 template would count the shape blend itself as stretching."""
        return self.ph.cloth_rest(shaped, self.rest.faces).to(like)

    def terms(self, x, x_t, x_tm1, material, dt, body_points, body_normals, body_points_t, rest=None):
        ph, torch = self.ph, self.torch
        if rest is None:
            if self._rest_t is None or self._rest_t.face_area.device != x.device:
                self._rest_t = self.rest.to(x)
            rest = self._rest_t
        m, mu, lam, k = material[0], material[1], material[2], material[3]
        mass = m * rest.vertex_area
        collision = ph.collision_energy(x, body_points, body_normals, self.eps, 1.0)
        with torch.no_grad():  # lagged normal force of the collision penalty (held fixed in the step)
            gap = torch.relu(self.eps - ((x - body_points) * body_normals).sum(-1))
            normal_force = 3.0 * gap * gap * float(self.collision_weight)
        return {
            "stretching": ph.stretching_energy(x, rest, mu, lam),
            "bending": ph.bending_energy(x, rest, k, wrap=True),
            "inertia": ph.inertia_energy(x, 2 * x_t - x_tm1, mass, dt),
            # relative to the previous state: same gradient, a value that reads as work done in the step
            "gravity": ph.gravity_energy(x, mass) - ph.gravity_energy(x_t, mass).detach(),
            "friction": ph.friction_energy(x, x_t, body_points - body_points_t, body_normals, normal_force,
                                           self.friction_mu, self.friction_eps),
            "collision": collision,
        }

    collision_weight = 1.0


def energies(template, faces, torch, device=None):
    return Energies(template, faces, torch, device=device)
