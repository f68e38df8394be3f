"""The reference simulation of a garment along a clip, cached on disk (it is the slow part: seconds per frame).

The simulation itself is `pleat.sim.scene.simulate` (the garment starts as the LBS-skinned, β-shaped template at the
clip's first pose, pushed out of the body, with zero velocity; one implicit-Euler step per clip frame at dt = 1/fps;
pinned vertices follow the body by LBS). This module only adds the cache, and the choice of teacher: `teacher` =
"blender" makes the same simulation with Blender's cloth instead (pleat_blender.teacher; needs bpy).

Cache key: SHA-256 of the garment arrays (template, faces, skin, shape blend shapes, pins), the body (template,
shape directions, skin weights, faces, joint regressor), β, material, the clip's arrays and fps, the frame count,
the solver settings, REFERENCE_VERSION and, for a teacher other than Pleat's simulator, its name. Files:
out/cache/sim/<key>.npz with positions [T, N, 3] f32 and the simulator's summary.
"""
import hashlib
import json
from dataclasses import asdict
from pathlib import Path

import numpy as np

from pleat import REPO_ROOT

REFERENCE_VERSION = 2
TEACHERS = ("pleat", "blender")      # Pleat's simulator (pleat.sim), Blender's cloth (pleat_blender.teacher)
DEFAULT_CACHE = REPO_ROOT / "out" / "cache" / "sim"


def _hash_arrays(h, *arrays):
    for a in arrays:
        a = np.ascontiguousarray(np.asarray(a))
        h.update(str((a.dtype.str, a.shape)).encode())
        h.update(a.tobytes())


def check_teacher(teacher):
    """The teacher's name, or ValueError naming the choices; for "blender", also when bpy does not import here."""
    if teacher not in TEACHERS:
        raise ValueError(f"teacher {teacher!r}: use one of {', '.join(TEACHERS)}")
    if teacher == "blender":
        from pleat_blender.teacher import available
        why = available()
        if why:
            raise ValueError(why)
    return teacher


def cache_key(garment, body, beta, material, clip, frames, settings, start_perturbation_m=0.0, teacher="pleat"):
    h = hashlib.sha256()
    h.update(f"pleat-eval-reference-v{REFERENCE_VERSION}".encode())
    _hash_arrays(h, garment.template, garment.faces, garment.skin_indices, garment.skin_weights,
                 garment.shape_blend, garment.pinned, body.v_template, body.shapedirs, body.weights, body.faces,
                 body.J_regressor, np.asarray(beta, np.float64), np.asarray(material, np.float64),
                 clip.local_rotations[:frames], clip.root_translation[:frames], clip.root_rotation[:frames],
                 np.float64(clip.fps))
    # The scene's lead-in (how the garment is brought onto frame 0) changes every frame after it, so it is part of
    # the key like the solver settings.
    from pleat.sim.scene import HOLD_FRAMES, LEAD_IN_FRAMES
    scene = dict(frames=int(frames), settings=asdict(settings), lead_in=LEAD_IN_FRAMES, hold=HOLD_FRAMES)
    if start_perturbation_m:
        scene["start_perturbation_m"] = float(start_perturbation_m)
    if len(garment.collision_exclude):     # only when set, so the keys of garments colliding with everything stay
        scene["collision_exclude"] = [int(j) for j in garment.collision_exclude]
    if teacher != "pleat":                 # only when set, so the keys of Pleat's own simulations stay
        scene["teacher"] = teacher
    if teacher == "blender":               # its scene's cloth and collision defaults
        from pleat_blender.cloth import fingerprint
        scene["teacher_settings"] = fingerprint()
    h.update(json.dumps(scene, sort_keys=True).encode())
    return h.hexdigest()[:32]


def _resolved(garment, clip, beta, frames, settings):
    """(frames T, solver settings, β) with the defaults: the whole clip, one step per clip frame, the mean body."""
    from pleat.sim import SolverSettings
    T = clip.num_frames if frames is None else min(frames, clip.num_frames)
    settings = settings or SolverSettings(dt_s=1.0 / clip.fps)
    beta = np.zeros(garment.shape_blend.shape[0]) if beta is None else np.asarray(beta, np.float64)
    return T, settings, beta


def cache_entry(garment, body, clip, beta, material, frames=None, settings=None, cache_dir=None,
                start_perturbation_m=0.0, teacher="pleat"):
    """(the cache file of this simulation, its key): where cached_simulate reads and writes it."""
    T, settings, beta = _resolved(garment, clip, beta, frames, settings)
    key = cache_key(garment, body, beta, material, clip, T, settings, start_perturbation_m, teacher)
    return Path(cache_dir or DEFAULT_CACHE) / f"{key}.npz", key


def simulate_uncached(garment, body, clip, beta, material, frames=None, settings=None, progress=False,
                      start_perturbation_m=0.0, teacher="pleat"):
    """The simulation cached_simulate caches, without the cache: (positions [T, N, 3] f32, summary). A training
    task on another machine runs this and sends the positions back to the caller's cache (pleat.train.simdata).
    Blender's cloth has one material (the add-on's light shirt): `material` and `settings` do not reach it."""
    from pleat.physics.materials import Material
    from pleat.sim.scene import simulate
    T, settings, beta = _resolved(garment, clip, beta, frames, settings)
    if check_teacher(teacher) == "blender":
        from pleat_blender.teacher import simulate as blender_simulate
        return blender_simulate(garment, body, clip, beta, T, start_perturbation_m, progress)
    positions, _, summary = simulate(garment, body, clip, beta, Material(*map(float, material)), T, settings,
                                     progress, keep_body=False, start_perturbation_m=start_perturbation_m)
    return positions, summary


def read_cached(path):
    """(positions, summary) of a cache file, or None when there is none."""
    path = Path(path)
    if not path.is_file():
        return None
    with np.load(path, allow_pickle=False) as z:
        return z["positions"], json.loads(str(z["summary"]))


def write_cached(path, positions, summary):
    """Stores a simulation in the cache (pleat.fileio: readers never see half a file, and a killed writer's
    temporary is removed by the next write)."""
    from pleat.fileio import save_npz
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    save_npz(path, compressed=True, positions=positions, summary=json.dumps(summary))


def cached_simulate(garment, body, clip, beta, material, frames=None, settings=None, cache_dir=None,
                    progress=True, start_perturbation_m=0.0, teacher="pleat"):
    """pleat.sim.scene.simulate (or the `teacher`'s simulation) through the on-disk cache. Returns (positions
    [T, N, 3] f32, info) where info has the key, whether it was a cache hit and the simulator's summary (seconds
    per frame, convergence)."""
    path, key = cache_entry(garment, body, clip, beta, material, frames, settings, cache_dir, start_perturbation_m,
                            teacher)
    hit = read_cached(path)
    if hit is not None:
        return hit[0], dict(key=key, cache_hit=True, path=str(path), summary=hit[1], teacher=teacher)
    positions, summary = simulate_uncached(garment, body, clip, beta, material, frames, settings, progress,
                                           start_perturbation_m, teacher)
    write_cached(path, positions, summary)
    return positions, dict(key=key, cache_hit=False, path=str(path), summary=summary, teacher=teacher)
