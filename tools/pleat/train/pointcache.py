"""A technical artist's own offline simulation as training data for `pleat-train simsup` (docs/training.md, "Your own
simulation (technical artists)").

A user simulation is a garment point cache (PC2 — what Blender, 3ds Max, Houdini and Maya export — or npz), the
motion it was simulated on (BVH, ideally the one `pleat-garment scene` wrote; any clip the loaders accept), and
optionally the garment mesh as OBJ (same vertex order as the cache) for a check. `user_sequences` turns each into a
training (or validation) sequence through `simdata.sequence`, exactly as the simulator's own segments are made.

PC2 layout (little-endian): 12-byte signature b"POINTCACHE2\\0", int32 version = 1, int32 point count N, float32
start frame, float32 sample rate (frames between samples), int32 sample count S, then S × N × 3 float32 (x, y, z of
every point of sample 0, then sample 1, ...). Sample k is at scene frame start + k · rate.

Frames: the motion's frame i is at scene frame `motion_start_frame` + i (default: the cache's start frame, i.e. the
cache's first sample is the motion's first frame). Every cache sample must fall on the motion; `skip_frames` leading
samples are left out of training (the lead-in that `pleat-garment scene` puts before the motion). When the
cache's rate (motion fps / sample rate) is not the training rate (`fps`, 30), positions are interpolated linearly
and the motion resampled.

Checks (each one line naming the file, `InputError`): PC2 signature, version, sizes against the file length,
finite values; point count against the garment's vertex count; the OBJ's vertex count and shape against the
garment (after units and axes, up to a rigid motion: catches reordered vertices and wrong units); frame coverage
against the motion; and that the cache follows the motion (its first frame within 10 cm of the skinned garment,
else it suggests the --units / --up that would fit).
"""
import json
import math
import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pleat.cli import InputError, read_by_suffix
from pleat.train import simdata

PC2_SIGNATURE = b"POINTCACHE2\0"
PC2_VERSION = 1
PC2_HEADER = struct.Struct("<12siiffi")          # signature, version, points, start frame, sample rate, samples
MAX_POINTS = 10_000_000
FOLLOW_LIMIT_M = 0.10                            # mean distance of frame 0 from the skinned garment
OBJ_SHAPE_LIMIT_M = 0.02                         # max distance of the OBJ from the garment (after a rigid fit)


@dataclass
class PointCache:
    positions: np.ndarray          # [S, N, 3] float32, in the file's units and axes
    start_frame: float = 0.0
    sample_rate: float = 1.0       # frames between samples
    path: str = ""

    @property
    def samples(self):
        return self.positions.shape[0]

    @property
    def points(self):
        return self.positions.shape[1]


# ---- PC2 -----------------------------------------------------------------------------------------------------------
def read_pc2(path):
    """A PC2 point cache, checked (structure, then values)."""
    path = Path(path)
    data = path.read_bytes()
    if len(data) < PC2_HEADER.size:
        raise InputError(path, f"is {len(data)} bytes: too short for a PC2 header ({PC2_HEADER.size} bytes)")
    sig, version, points, start, rate, samples = PC2_HEADER.unpack_from(data, 0)
    if sig != PC2_SIGNATURE:
        raise InputError(path, f"does not start with 'POINTCACHE2' (found {sig[:11]!r}): not a PC2 file")
    if version != PC2_VERSION:
        raise InputError(path, f"is PC2 version {version}; only version {PC2_VERSION} exists")
    if not 0 < points <= MAX_POINTS:
        raise InputError(path, f"point count {points} is not in 1..{MAX_POINTS}")
    if samples < 1:
        raise InputError(path, f"sample count {samples}: the cache has no samples")
    if not (math.isfinite(start) and math.isfinite(rate) and rate > 0):
        raise InputError(path, f"start frame {start:g} / sample rate {rate:g}: the rate (frames between samples) "
                               "must be a positive number")
    expected = PC2_HEADER.size + 12 * points * samples
    if len(data) != expected:
        what = "truncated" if len(data) < expected else "trailing bytes"
        raise InputError(path, f"is {len(data)} bytes; {samples} samples × {points} points need {expected} "
                               f"({what})")
    pos = np.frombuffer(data, "<f4", count=samples * points * 3, offset=PC2_HEADER.size)
    pos = pos.reshape(samples, points, 3).astype(np.float32)
    _check_finite(path, pos)
    return PointCache(pos, float(start), float(rate), str(path))


def write_pc2(path, positions, start_frame=0.0, sample_rate=1.0):
    """positions [S, N, 3] → a PC2 file (float32, little-endian), written atomically."""
    from pleat.fileio import write_bytes
    pos = np.ascontiguousarray(positions, "<f4")
    if pos.ndim != 3 or pos.shape[2] != 3:
        raise ValueError(f"positions must be [samples, points, 3], got {pos.shape}")
    head = PC2_HEADER.pack(PC2_SIGNATURE, PC2_VERSION, pos.shape[1], float(start_frame), float(sample_rate),
                           pos.shape[0])
    write_bytes(path, head + pos.tobytes())
    return Path(path)


def _check_finite(path, pos):
    bad = ~np.isfinite(pos).all(axis=-1)
    if bad.any():
        s, v = (int(i) for i in np.argwhere(bad)[0])
        raise InputError(path, f"sample {s}, point {v} is not finite ({pos[s, v].tolist()}): the simulation blew "
                               f"up or the file is damaged ({int(bad.sum())} such points)")


# ---- npz -----------------------------------------------------------------------------------------------------------
def read_npz_cache(path):
    """{positions [T, N, 3]} (optional start_frame, sample_rate), checked."""
    from pleat.cli import not_npz
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            if "positions" not in z.files:
                raise InputError(path, f"npz point cache without 'positions' (has {', '.join(z.files) or 'nothing'})")
            pos = np.asarray(z["positions"])
            start = float(z["start_frame"]) if "start_frame" in z.files else 0.0
            rate = float(z["sample_rate"]) if "sample_rate" in z.files else 1.0
    except InputError:
        raise
    except (OSError, ValueError, EOFError) as exc:
        raise not_npz(path, exc, "a point cache") from None
    if pos.ndim != 3 or pos.shape[2] != 3 or pos.shape[0] < 1 or pos.shape[1] < 1:
        raise InputError(path, f"positions have shape {list(pos.shape)}; expected [frames, vertices, 3]")
    if not np.issubdtype(pos.dtype, np.floating):
        raise InputError(path, f"positions are {pos.dtype}, not floating point")
    if not (math.isfinite(start) and math.isfinite(rate) and rate > 0):
        raise InputError(path, f"start_frame {start:g} / sample_rate {rate:g} are not valid")
    pos = pos.astype(np.float32)
    _check_finite(path, pos)
    return PointCache(pos, start, rate, str(path))


def write_npz_cache(path, positions, start_frame=0.0, sample_rate=1.0):
    from pleat.fileio import save_npz
    return save_npz(path, positions=np.asarray(positions, np.float32), start_frame=np.float64(start_frame),
                    sample_rate=np.float64(sample_rate))


def read_cache(path):
    """A point cache by suffix: .pc2 or .npz."""
    return read_by_suffix(path, {".pc2": read_pc2, ".npz": read_npz_cache}, "point cache")


# ---- motion ----------------------------------------------------------------------------------------------------------
def load_motion(name_or_path, body):
    """The clip a user simulation was made on: a BVH of the Pleat skeleton (`pleat-garment scene`) exactly, anything
    else through pleat.motion.load_clip (retargeted and grounded: the same clip `pleat-garment scene --motion`
    poses the body with)."""
    from pleat.motion import load_clip
    from pleat.motion.bvh_export import read_pleat_bvh
    p = Path(name_or_path)
    if p.suffix.lower() == ".bvh" and p.is_file():
        clip = read_pleat_bvh(p, body)
        if clip is not None:
            return clip
    return load_clip(name_or_path, body=body)


# ---- user simulation specs -------------------------------------------------------------------------------------------
@dataclass
class UserSim:
    """One user simulation (a manifest entry or a --user-sim key=value list)."""
    cache: str
    motion: str
    garment_obj: str = None
    beta: tuple = ()
    material: tuple = None          # (m kg/m², μ, λ, k); default: the asset's default material
    units: str = "m"
    up: str = "y"
    motion_start_frame: float = None
    skip_frames: int = 0
    role: str = "train"             # train | validation
    name: str = ""
    origin: str = field(default="", repr=False)


_KEYS = {"cache", "motion", "garment_obj", "obj", "beta", "material", "units", "up", "motion_start_frame",
         "skip_frames", "role", "name"}


def _entry(d, base, origin):
    if not isinstance(d, dict):
        raise InputError(origin, f"a user simulation must be an object with cache and motion, got {d!r:.60}")
    unknown = set(d) - _KEYS
    if unknown:
        raise InputError(origin, f"unknown key(s) {', '.join(sorted(unknown))} (known: {', '.join(sorted(_KEYS))})")
    for k in ("cache", "motion"):
        if not d.get(k):
            raise InputError(origin, f"a user simulation needs {k!r}")

    def rel(p):
        if p is None:
            return None
        q = Path(p)
        return str(q if q.is_absolute() or base is None else base / q)

    def floats(v, what):
        if v is None:
            return None
        if isinstance(v, str):
            v = [x for x in v.replace(":", " ").replace(",", " ").split()]
        try:
            out = tuple(float(x) for x in v)
        except (TypeError, ValueError):
            raise InputError(origin, f"{what} must be numbers, got {v!r:.60}") from None
        if not all(math.isfinite(x) for x in out):
            raise InputError(origin, f"{what} must be finite, got {out}")
        return out

    role = d.get("role", "train")
    if role not in ("train", "validation"):
        raise InputError(origin, f"role {role!r}: use train or validation")
    motion = d["motion"]
    motion_path = rel(motion)
    if not Path(motion_path).exists() and not Path(motion).suffix:
        motion_path = motion            # a clip name from the motion folder
    try:
        skip = int(d.get("skip_frames", 0))
        start = None if d.get("motion_start_frame") is None else float(d["motion_start_frame"])
    except (TypeError, ValueError):
        raise InputError(origin, "skip_frames must be an integer and motion_start_frame a number") from None
    if skip < 0:
        raise InputError(origin, f"skip_frames {skip} must be ≥ 0")
    return UserSim(cache=rel(d["cache"]), motion=motion_path, garment_obj=rel(d.get("garment_obj", d.get("obj"))),
                   beta=floats(d.get("beta"), "beta") or (), material=floats(d.get("material"), "material"),
                   units=str(d.get("units", "m")), up=str(d.get("up", "y")), motion_start_frame=start,
                   skip_frames=skip, role=role, name=str(d.get("name") or Path(d["cache"]).stem), origin=str(origin))


def parse_user_sims(specs):
    """--user-sim values → [UserSim]: each a JSON manifest (a list of entries, or {"simulations": [...]}; relative
    paths are relative to the manifest) or `cache=PATH,motion=PATH[,obj=PATH][,units=cm][,up=z][,beta=b0:b1...]
    [,material=m:mu:lambda:k][,skip_frames=N][,motion_start_frame=F][,role=validation]`."""
    out = []
    for spec in specs or []:
        spec = str(spec)
        if spec.lower().endswith(".json"):
            path = Path(spec)
            if not path.is_file():
                raise InputError(path, "no such user simulation manifest")
            try:
                doc = json.loads(path.read_text(encoding="utf-8"))
            except (UnicodeDecodeError, json.JSONDecodeError) as exc:
                raise InputError(path, f"manifest is not valid JSON ({exc})") from None
            entries = doc.get("simulations") if isinstance(doc, dict) else doc
            if isinstance(doc, dict) and entries is None:
                entries = [doc]
            if not isinstance(entries, list) or not entries:
                raise InputError(path, 'manifest must be a list of simulations or {"simulations": [...]}')
            out += [_entry(e, path.parent, f"{path} entry {i}") for i, e in enumerate(entries)]
        else:
            d = {}
            for part in spec.split(","):
                key, sep, value = part.partition("=")
                if not sep:
                    raise InputError(None, f"--user-sim {spec!r}: expected key=value pairs separated by commas "
                                           "(cache=..., motion=...) or a .json manifest")
                d[key.strip()] = value.strip()
            out.append(_entry(d, None, f"--user-sim {spec}"))
    return out


# ---- checks and conversion -------------------------------------------------------------------------------------------
def _rigid_residual(a, b):
    """Max distance between point sets a and b [N, 3] (same order) after the best rigid motion (Kabsch)."""
    ca, cb = a.mean(0), b.mean(0)
    H = (a - ca).T @ (b - cb)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(Vt.T @ U.T))
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    return float(np.linalg.norm((a - ca) @ R.T + cb - b, axis=1).max())


def check_obj(sim, garment_rest, up, units):
    """The OBJ the cache was made from is the garment: same vertex count, same shape in the same vertex order (up
    to a rigid motion, so the start-posed OBJ of `pleat-garment scene` passes). Returns the residual, m."""
    from pleat.garment.meshio import read_mesh, to_pleat_axes
    mesh = read_mesh(sim.garment_obj)
    N = len(garment_rest)
    if len(mesh.vertices) != N:
        raise InputError(sim.garment_obj, f"has {len(mesh.vertices)} vertices; the garment has {N}: not the mesh "
                                          "that was imported (simulate the mesh `pleat-garment import --write-obj` "
                                          "wrote)")
    x = to_pleat_axes(mesh.vertices, up, units)
    res = _rigid_residual(x, garment_rest)
    if res > OBJ_SHAPE_LIMIT_M:
        from scipy.spatial import cKDTree
        near = float(cKDTree(x).query(garment_rest)[0].max())
        scale = float(np.linalg.norm(x - x.mean(0), axis=1).mean() /
                      max(np.linalg.norm(garment_rest - garment_rest.mean(0), axis=1).mean(), 1e-12))
        if near < OBJ_SHAPE_LIMIT_M:
            why = "the same points in another vertex order: the DCC tool reordered the vertices on export"
        elif abs(scale - 1.0) > 0.2:
            why = f"{scale:.3g}× the garment's size: wrong units (units={units})?"
        else:
            why = "a different shape (wrong up axis, or another mesh?)"
        raise InputError(sim.garment_obj, f"does not match the garment (max {res * 100:.1f} cm off after a rigid "
                                          f"fit): {why}")
    return res


def _frame_map(sim, cache, clip):
    """Motion frame (float) of every cache sample, checked against the motion's length."""
    start = cache.start_frame if sim.motion_start_frame is None else sim.motion_start_frame
    idx = cache.start_frame + cache.sample_rate * np.arange(cache.samples) - start
    last = clip.num_frames - 1
    eps = 1e-4
    if idx[0] < -eps:
        raise InputError(sim.cache, f"starts at scene frame {cache.start_frame:g}, before the motion's first frame "
                                    f"(scene frame {start:g}; motion_start_frame): every sample must fall on the "
                                    "motion")
    if idx[-1] > last + eps:
        raise InputError(sim.cache, f"has {cache.samples} samples (scene frames {cache.start_frame:g}.."
                                    f"{cache.start_frame + cache.sample_rate * (cache.samples - 1):g}) but the motion "
                                    f"{Path(str(sim.motion)).name} has {clip.num_frames} frames (scene frames "
                                    f"{start:g}..{start + last:g}): frame count mismatch — cache the motion's range "
                                    "only, or set motion_start_frame")
    return np.clip(idx, 0.0, last)


def _at_frames(clip, idx):
    """The clip at (fractional) frames idx: exact frames when they are integers, else Clip.sample."""
    if np.allclose(idx, np.round(idx), atol=1e-6):
        return clip.frames_at(np.round(idx).astype(np.int64))
    from pleat.motion.clip import Clip
    q, t, r = clip.sample(idx / clip.fps)
    return Clip(name=clip.name, fps=clip.fps, local_rotations=q, root_translation=t, root_rotation=r,
                source=clip.source, joint_names=clip.joint_names)


def _resample(clip, positions, fps):
    """Clip and positions at `fps` (slerp / linear interpolation) when their rate differs from it."""
    from dataclasses import replace
    if abs(clip.fps - fps) <= 1e-6 * fps:
        return clip, positions
    T = len(positions)
    n = int(math.floor((T - 1) / clip.fps * fps + 1e-9)) + 1
    t = np.arange(n) / fps
    x = t * clip.fps
    i0 = np.minimum(np.floor(x).astype(np.int64), T - 1)
    i1 = np.minimum(i0 + 1, T - 1)
    a = (x - i0)[:, None, None]
    pos = positions[i0] * (1 - a) + positions[i1] * a
    q, tr, r = clip.sample(t)
    return replace(clip, fps=float(fps), local_rotations=q, root_translation=tr, root_rotation=r), pos


def _skinned(setup, M, beta):
    """(per-vertex LBS transforms, β-shaped template, the template skinned) for joint matrices M [T, J, 3, 4]."""
    A = simdata.blend_matrices(setup, M)
    shaped = setup.shaped(beta)
    return A, shaped, np.einsum("tnab,nb->tna", A[..., :3], shaped) + A[..., 3]


def _check_follows(sim, setup, clip, beta, cache, pos0):
    """The cache's first sample must be near the garment skinned onto the motion's first frame; if it is not, try
    the other units and up axes and say which would fit."""
    from pleat.garment.meshio import UNITS_M, to_pleat_axes
    _, _, lbs = _skinned(setup, simdata.joint_matrices(setup, clip, beta, 1), beta)
    err = float(np.linalg.norm(pos0 - lbs[0], axis=1).mean())
    if err <= FOLLOW_LIMIT_M:
        return err
    raw = cache.positions[0]
    tries = []
    for up in ("y", "z"):
        for units in UNITS_M:
            e = float(np.linalg.norm(to_pleat_axes(raw, up, units) - lbs[0], axis=1).mean())
            tries.append((e, up, units))
    e, up, units = min(tries)
    hint = (f"; with up={up}, units={units} it would be {e * 100:.1f} cm" if e <= FOLLOW_LIMIT_M else
            "; no units/up setting fits: was it simulated on this motion, with the body of `pleat-garment scene`?")
    raise InputError(sim.cache, f"its first frame is {err * 100:.1f} cm (mean) from the garment skinned onto the "
                                f"motion's first frame (up={sim.up}, units={sim.units}){hint}")


def load_user_sim(setup, sim, fps):
    """One user simulation → (sequence dict for simdata / posed_errors, info dict)."""
    from pleat import garment_asset as ga
    from pleat.garment.meshio import to_pleat_axes
    cache = read_cache(sim.cache)
    if cache.points != setup.N:
        raise InputError(sim.cache, f"has {cache.points} points; the garment {setup.name} has {setup.N} vertices: "
                                    "the cache is not of this garment (simulate the mesh pleat-garment import "
                                    "--write-obj or pleat-garment scene wrote, and pass the same --garment)")
    try:
        positions = to_pleat_axes(cache.positions, sim.up, sim.units)
    except ValueError as exc:
        raise InputError(sim.origin, str(exc)) from None
    beta = np.zeros(setup.B)
    if len(sim.beta) > setup.B:
        raise InputError(sim.origin, f"beta has {len(sim.beta)} values; the body has {setup.B}")
    beta[:len(sim.beta)] = sim.beta
    if np.abs(beta).max(initial=0.0) > max(abs(v) for v in ga.BETA_RANGE):
        raise InputError(sim.origin, f"beta {beta.tolist()} is outside the asset's range {ga.BETA_RANGE}")
    material = np.array(ga.MATERIAL_DEFAULT if sim.material is None else sim.material, np.float64)
    if material.shape != (4,):
        raise InputError(sim.origin, "material needs 4 values (m kg/m², μ N/m, λ N/m, k)")
    lo, hi = np.array(ga.MATERIAL_MIN), np.array(ga.MATERIAL_MAX)
    if np.any(material < lo * (1 - 1e-6)) or np.any(material > hi * (1 + 1e-6)):
        raise InputError(sim.origin, f"material {material.tolist()} is outside the asset's ranges "
                                     f"{list(ga.MATERIAL_MIN)} .. {list(ga.MATERIAL_MAX)}")
    obj_res = None
    if sim.garment_obj:
        obj_res = check_obj(sim, setup.shaped(beta), sim.up, sim.units)
    clip = load_motion(sim.motion, setup.body)
    idx = _frame_map(sim, cache, clip)
    if sim.skip_frames >= len(idx) - 1:
        raise InputError(sim.cache, f"has {len(idx)} samples; skip_frames {sim.skip_frames} leaves fewer than 2")
    idx, positions = idx[sim.skip_frames:], positions[sim.skip_frames:]
    seg = _at_frames(clip, idx)
    seg.fps = clip.fps / cache.sample_rate
    seg, positions = _resample(seg, positions, fps)
    if len(positions) < 2:
        raise InputError(sim.cache, f"covers {len(positions)} frame at {fps:g} fps; a sequence needs at least 2")
    follow = _check_follows(sim, setup, seg, beta, cache, positions[0])
    s = simdata.sequence(setup, seg, beta, material, positions)
    A, shaped, lbs = _skinned(setup, s["M"], beta)
    lbs_mm = 1e3 * float(np.linalg.norm(positions - lbs, axis=-1).mean())
    if sim.role == "validation":
        s.update(A=A, shaped=shaped, positions=positions, name=sim.name)
    info = {"name": sim.name, "role": sim.role, "cache": str(sim.cache), "motion": str(sim.motion),
            "frames": int(len(positions)), "fps": float(fps), "cache_fps": float(clip.fps / cache.sample_rate),
            "beta": beta.tolist(), "material": material.tolist(), "units": sim.units, "up": sim.up,
            "first_frame_from_lbs_mm": 1e3 * follow, "mean_from_lbs_mm": lbs_mm,
            "obj_residual_mm": None if obj_res is None else 1e3 * obj_res}
    return s, info


def user_sequences(setup, specs, fps, log=None):
    """--user-sim values → (training sequences, validation sequences, infos). Every simulation is read and checked
    before any is used, so a bad file stops the run before training starts."""
    sims = parse_user_sims(specs)
    train, val, infos = [], [], []
    for sim in sims:
        s, info = load_user_sim(setup, sim, fps)
        (val if sim.role == "validation" else train).append(s)
        infos.append(info)
        if log is not None:
            log({"user_simulation": info})
    return train, val, infos


def info_line(info):
    """One line per user simulation for the run's output."""
    return (f"user simulation {info['name']} ({info['role']}): {info['frames']} frames at {info['fps']:g} fps "
            f"(cache {info['cache_fps']:g} fps), {info['mean_from_lbs_mm']:.1f} mm from LBS-only on average")
