"""The reference simulation of a garment along a clip, cached on disk (it is the slow part: ~1–2 s per frame).

The garment starts as the LBS-skinned, β-shaped template at the clip's first pose with zero velocity and is first
simulated for `settle_frames` steps on that pose, so the reference at frame 0 hangs at rest as Pleat's first frame
(zero velocities) assumes. Each clip frame then takes one implicit-Euler step of `pleat.sim.ClothSolver` at dt = 1/fps
against the posed body of that frame; pinned vertices follow the body by LBS.

Cache key: SHA-256 of the garment arrays (template, faces, skin, shape blend shapes, pins), β, material, the clip's
arrays and fps, the frame count, the settle count, the solver settings and REFERENCE_VERSION. Files:
out/cache/sim/<key>.npz with positions [T, N, 3] f32 and per-frame solver statistics.
"""
import hashlib
import json
import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

from pleat import REPO_ROOT

REFERENCE_VERSION = 1
DEFAULT_CACHE = REPO_ROOT / "out" / "cache" / "sim"


def _hash_arrays(h, *arrays):
    for a in arrays:
        a = np.ascontiguousarray(np.asarray(a))
        h.update(str((a.dtype.str, a.shape)).encode())
        h.update(a.tobytes())


def cache_key(garment, beta, material, clip, frames, settings, settle_frames):
    h = hashlib.sha256()
    h.update(f"pleat-eval-reference-v{REFERENCE_VERSION}".encode())
    _hash_arrays(h, garment.template, garment.faces, garment.skin_indices, garment.skin_weights,
                 garment.shape_blend, garment.pinned, np.asarray(beta, np.float64), np.asarray(material, np.float64),
                 clip.local_rotations[:frames], clip.root_translation[:frames], clip.root_rotation[:frames],
                 np.float64(clip.fps))
    h.update(json.dumps(dict(frames=int(frames), settle=int(settle_frames), settings=asdict(settings)),
                        sort_keys=True).encode())
    return h.hexdigest()[:32]


def simulate(garment, body, clip, beta, material, frames=None, settle_frames=10, settings=None, progress=True):
    """Reference positions [T, N, 3] (float32) and per-frame stats (list of dicts)."""
    from pleat.physics.energies import cloth_rest
    from pleat.physics.materials import Material
    from pleat.sim import BodyCollider, ClothSolver, SolverSettings
    from pleat.eval.scene import posed_body

    T = clip.num_frames if frames is None else min(frames, clip.num_frames)
    settings = settings or SolverSettings(dt_s=1.0 / clip.fps)
    beta = np.zeros(garment.shape_blend.shape[0]) if beta is None else np.asarray(beta, np.float64)
    body_v, M = posed_body(body, _cut(clip, T), beta)
    rest_shape = garment.shaped(beta)
    solver = ClothSolver(cloth_rest(rest_shape, garment.faces), Material(*map(float, material)), garment.pinned,
                         settings)
    lbs = garment.skin(M, beta)                                    # [T, N, 3] pin targets and start
    x = lbs[0].copy()
    x_prev = x.copy()
    col0 = BodyCollider(body_v[0], body.faces)
    for _ in range(settle_frames):
        x_new, _ = solver.step(x, x_prev, lbs[0], col0, col0)
        x_prev, x = x, x_new
    x_prev = x.copy()                                              # frame 0 at rest: zero velocity
    out = np.empty((T,) + x.shape, np.float32)
    out[0] = x
    stats = [dict(newton=0, converged=True, seconds=0.0)]
    col_prev = col0
    bar = _progress(T, progress)
    for t in range(1, T):
        t0 = time.perf_counter()
        col = BodyCollider(body_v[t], body.faces)
        x_new, st = solver.step(x, x_prev, lbs[t], col_prev, col)
        x_prev, x, col_prev = x, x_new, col
        out[t] = x
        stats.append(dict(newton=st.newton_iterations, converged=bool(st.converged),
                          gradient_norm=st.gradient_norm, seconds=time.perf_counter() - t0))
        bar(t)
    bar(None)
    return out, stats


def _cut(clip, T):
    from dataclasses import replace
    return replace(clip, local_rotations=clip.local_rotations[:T], root_translation=clip.root_translation[:T],
                   root_rotation=clip.root_rotation[:T])


def _progress(total, enabled):
    if not enabled:
        return lambda t: None
    try:
        from tqdm import tqdm
    except ImportError:
        return lambda t: None
    bar = tqdm(total=total - 1, desc="reference sim", unit="frame", file=sys.stderr)

    def update(t):
        if t is None:
            bar.close()
        else:
            bar.update(1)
    return update


def cached_simulate(garment, body, clip, beta, material, frames=None, settle_frames=10, settings=None,
                    cache_dir=None, progress=True):
    """simulate(...) through the on-disk cache. Returns (positions, info) where info has the key, whether it was a
    cache hit and the solver's mean seconds per frame."""
    from pleat.sim import SolverSettings
    T = clip.num_frames if frames is None else min(frames, clip.num_frames)
    settings = settings or SolverSettings(dt_s=1.0 / clip.fps)
    beta = np.zeros(garment.shape_blend.shape[0]) if beta is None else np.asarray(beta, np.float64)
    key = cache_key(garment, beta, material, clip, T, settings, settle_frames)
    cache_dir = Path(cache_dir or DEFAULT_CACHE)
    path = cache_dir / f"{key}.npz"
    if path.is_file():
        with np.load(path, allow_pickle=False) as z:
            return z["positions"], dict(key=key, cache_hit=True, path=str(path),
                                        seconds_per_frame=float(z["seconds_per_frame"]),
                                        converged_share=float(z["converged_share"]))
    t0 = time.perf_counter()
    positions, stats = simulate(garment, body, clip, beta, material, T, settle_frames, settings, progress)
    spf = (time.perf_counter() - t0) / max(1, T - 1 + settle_frames)
    converged = float(np.mean([s["converged"] for s in stats]))
    cache_dir.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npz")
    np.savez_compressed(tmp, positions=positions, seconds_per_frame=spf, converged_share=converged,
                        newton=np.array([s["newton"] for s in stats]))
    tmp.replace(path)
    return positions, dict(key=key, cache_hit=False, path=str(path), seconds_per_frame=spf,
                           converged_share=converged)
