"""Simulated garment sequences for the simulator-supervised recipe (docs/training.md, "Recipes").

The reference simulator (`pleat.sim`) is the teacher: training clips, and their variants (VARIANTS: mirrored,
time-scaled, ...), are cut into segments; each segment is simulated at its own sampled β and material on `workers`
processes. Every segment goes through pleat-eval's on-disk cache (`pleat.eval.reference`: same key, same folder), so
a rerun or a resumed run never simulates a segment twice, and a time budget only decides how many segments there
are. The cache stays with the caller; the misses are simulated as tasks (pleat.train.tasks: this machine's processes
or Ray), which send their frames back.

A simulated frame becomes a training target by un-skinning it: LBS is an invertible affine map per vertex
(x = A·v + a with A = Σ_k w_k R_k), so d = A⁻¹(x − a) − (T + G_S(β)) is exactly the rest-frame displacement the
runtime's blend shapes must add for the runtime to reproduce the simulated frame. A user's own offline
simulation (`pleat.train.pointcache`) becomes segments of the same kind.
"""
import os
import time
import zlib
from dataclasses import dataclass, replace

import numpy as np

from pleat import garment_asset as ga
from pleat.train import sources

# The variants of a training clip the data is drawn from: (name, time scale). Mirroring swaps left and right; a
# time scale above 1 plays the clip faster (fast motion is where learned cloth breaks first, docs/stability.md);
# "collar" moves COLLAR_SHARE of each shoulder's rotation into its collar (Clip.with_collar_share): the training
# clips have no clavicle motion, a user's mocap usually has (docs/accuracy.md); "stop" plays the clip in pieces of
# STOP_MOVE_S, each followed by a hold of STOP_HOLD_S (Clip.with_holds): the training clips loop and never stop dead,
# so without it the model never sees the cloth swing on after the body stops; "blend" plays the clip into another
# training clip (blend_partner) with a BLEND_S cross-fade (pleat.motion.clip.concatenate), and its segments are the
# windows around that seam: the training clips never change from one motion to another; "noise" adds a smooth random
# offset of at most NOISE_AMPLITUDE_RAD to every joint but the root, within the clip's own joint ranges
# (Clip.with_pose_noise): poses near, not on, the training motion's.
VARIANTS = (("original", 1.0), ("mirrored", 1.0), ("fast", 1.5), ("slow", 0.7), ("collar", 1.0), ("stop", 1.0),
            ("blend", 1.0), ("noise", 1.0))
COLLAR_SHARE = 0.25
STOP_MOVE_S = 1.2
STOP_HOLD_S = 0.8
BLEND_S = 0.5
NOISE_AMPLITUDE_RAD = 0.1


@dataclass(frozen=True)
class Segment:
    """One simulated sequence: frames [start, start + frames) of a variant of a training clip."""
    clip: str
    variant: str
    start: int
    frames: int
    beta: tuple
    material: tuple
    partner: str = ""       # the clip a "blend" segment cross-fades into; "" for the other variants

    @property
    def clip_names(self):
        """The training clips the segment is made from: its clip, and a "blend" segment's partner."""
        return (self.clip, self.partner) if self.partner else (self.clip,)


def variant_clip(clip, variant, partner=None):
    """The pleat.motion Clip played as `variant` (see VARIANTS), at the clip's own frame rate; "blend" needs the
    `partner` Clip it cross-fades into (the one Segment.partner names)."""
    scale = dict(VARIANTS)[variant]
    if variant == "mirrored":
        clip = clip.mirrored()
    if variant == "collar":
        clip = clip.with_collar_share(COLLAR_SHARE)
    if variant == "stop":
        clip = clip.with_holds(round(STOP_MOVE_S * clip.fps), round(STOP_HOLD_S * clip.fps))
    if variant == "blend":
        from pleat.motion.clip import concatenate
        if partner is None:
            raise ValueError(f"the blend variant of {clip.name} needs the clip it blends into")
        clip = concatenate(clip, partner, BLEND_S)
    if variant == "noise":
        clip = clip.with_pose_noise(NOISE_AMPLITUDE_RAD, noise_seed(clip.name))
    if scale != 1.0:
        clip = clip.time_scaled(scale)
    return clip


def noise_seed(clip_name):
    """The "noise" variant's seed: a stable hash of the clip's name (Python's hash() of a string changes from one
    process to the next), so every process and every rerun builds the same noisy clip, and its cache key holds."""
    return zlib.crc32(clip_name.encode("utf-8"))


def blend_partner(names, name):
    """The clip a "blend" segment of `name` cross-fades into: the next of `names` in sorted order, wrapping (a lone
    clip blends into itself, its end into its start). The names alone decide it, so a rerun plans the same pairs."""
    ordered = sorted(names)
    return ordered[(ordered.index(name) + 1) % len(ordered)]


def blend_seam(clip, partner):
    """Frames [first, end) of the "blend" variant where `clip` cross-fades into `partner`."""
    from pleat.motion.clip import crossfade_frames
    n = crossfade_frames(clip, partner, BLEND_S)
    return clip.num_frames - n, clip.num_frames


def segment_clip(clips, segment):
    """The Clip a segment simulates, rebuilt from {name: Clip} holding its clip and, for "blend", its partner."""
    partner = clips[segment.partner] if segment.partner else None
    return cut(variant_clip(clips[segment.clip], segment.variant, partner), segment.start, segment.frames)


def cut(clip, start, frames):
    """Frames [start, start + frames) of a Clip."""
    return clip.frames_at(slice(start, start + frames))


def sample_beta(rng, count, scale, limit):
    """β ~ N(0, scale²) per component, clipped to ±limit: most bodies near the mean, some far from it."""
    return np.clip(rng.normal(0.0, scale, count), -limit, limit)


def sample_material(rng, default_share):
    """The asset's default material with probability `default_share`, else uniform in the paper's ranges."""
    if rng.uniform() < default_share:
        return np.array(ga.MATERIAL_DEFAULT, np.float64)
    lo, hi = np.array(ga.MATERIAL_MIN), np.array(ga.MATERIAL_MAX)
    return lo + rng.uniform(0.0, 1.0, 4) * (hi - lo)


def window_starts(num_frames, frames, cover=None):
    """Starts of `frames`-frame windows, half overlapping, over a clip of `num_frames` frames. Given cover = (first,
    end), only the windows that hold frames [first, end) whole, centred in the range where such windows can start
    (so there is motion on both sides of what they cover)."""
    step = max(frames // 2, 1)
    lo, hi = 0, max(num_frames - frames, 0)
    if cover is not None:
        first, end = cover
        hi = min(hi, first)
        lo = min(max(lo, end - frames), hi)      # a cover longer than the window: the window that starts with it
        lo += (hi - lo) % step // 2
    return list(range(lo, hi + 1, step))


def plan_segments(clips, cfg, beta_count, seed):
    """The segments to simulate, in the order they are worth simulating: round-robin over (clip, variant) so that a
    run stopped by its time budget still covers every clip. The first segment of every clip is at β = 0 and the
    default material (the validation setting). A "blend" segment's partner is one of `clips` (blend_partner), and
    its windows are those around the seam."""
    rng = np.random.default_rng([seed, 11])
    F = int(cfg["segment_frames"])
    by_name = {clip.name: clip for clip in clips}
    per_source = []
    for clip in clips:
        for variant, _ in VARIANTS:
            if variant not in cfg["variants"]:
                continue
            partner = blend_partner(by_name, clip.name) if variant == "blend" else ""
            T = variant_clip(clip, variant, by_name.get(partner)).num_frames
            frames = min(F, T)
            starts = window_starts(T, frames, blend_seam(clip, by_name[partner]) if partner else None)
            rng.shuffle(starts)
            per_source.append([(clip.name, variant, int(s), int(frames), partner) for s in starts])
    order = []
    rounds = max(len(s) for s in per_source) * int(cfg["repeats"])
    for r in range(rounds):
        for src in per_source:
            if src:
                order.append(src[r % len(src)])
    segments = []
    for k, (name, variant, start, frames, partner) in enumerate(order):
        first = k < len(per_source) and variant == "original"
        beta = np.zeros(beta_count) if first else sample_beta(rng, beta_count, cfg["beta_scale"], cfg["beta_max"])
        mat = np.array(ga.MATERIAL_DEFAULT) if first else sample_material(rng, cfg["default_material_share"])
        if cfg["teacher"] != "pleat":      # Blender's cloth has one material (pleat.eval.reference); same β draws
            mat = np.array(ga.MATERIAL_DEFAULT)
        segments.append(Segment(name, variant, start, frames, tuple(map(float, beta)), tuple(map(float, mat)),
                                partner))
    return segments


# ---- simulation as tasks (pleat.train.tasks) --------------------------------------------------------------------
_STATE = {}


def _state(context):
    """The garment, body and clips of a simulation context, built once per process (a pool worker, a Ray task's
    worker, or the caller for the cache keys)."""
    token = context["token"]
    state = _STATE.get(token)
    if state is None:
        from pleat.body import BodyModel
        from pleat.garment import Garment
        from pleat.motion import load_clip
        body = BodyModel.load(context["body_path"])
        # named by their split names, as the caller's are: the "noise" variant's seed is the clip's name
        state = dict(body=body, garment=Garment.build(**context["garment"]),
                     clips={n: replace(load_clip(n, body=body).resample(context["fps"]), name=n)
                            for n in context["clips"]})
        while len(_STATE) >= 8:       # a worker of a wardrobe build sees a context per garment: keep the latest
            _STATE.pop(next(iter(_STATE)))
        _STATE[token] = state
    return state


def _simulate_segment(context, segment):
    """One segment simulated where the task runs: (positions [T, N, 3] f32, the simulator's summary, CPU s). Touches
    no file, so it runs on any node of a cluster."""
    from pleat.eval.reference import simulate_uncached
    state = _state(context)
    t0 = time.process_time()
    positions, summary = simulate_uncached(state["garment"], state["body"], segment_clip(state["clips"], segment),
                                           np.array(segment.beta), np.array(segment.material), segment.frames,
                                           teacher=context.get("teacher", "pleat"))
    return positions, summary, time.process_time() - t0


def garment_arrays(setup):
    """What pleat.garment.Garment.build needs, from the training setup's garment (the asset's own arrays)."""
    return dict(name=setup.name, template=setup.template, faces=setup.faces, skin_indices=setup.skin_indices,
                skin_weights=setup.skin_weights, shape_blend=setup.shape_blend, pinned=setup.pinned,
                collision_exclude=np.asarray(sources.field(setup.garment, "collision_exclude", ()), np.int32))


def simulate_segments(setup, segments, workers, cache_dir, deadline=None, log=None, runner=None):
    """Simulates the segments through the simulation cache until done or past `deadline` (time.time()): the cache
    is read and written here, the misses are simulated as tasks of `runner` (pleat.train.tasks; default
    `workers` processes of this machine), each written to the cache and logged as soon as it comes back (a run
    stopped half-way keeps what it simulated). Returns [(segment, cache path)] of those finished and the CPU seconds
    spent (cache hits cost 0)."""
    import uuid

    from pleat import REPO_ROOT
    from pleat.eval.reference import cache_entry, write_cached
    from pleat.train import tasks
    runner = runner or tasks.Local(workers)
    body_path = str(REPO_ROOT / setup.cfg["body"]) if not os.path.isabs(setup.cfg["body"]) else setup.cfg["body"]
    teacher = setup.cfg["simsup"]["teacher"]
    context = dict(token=uuid.uuid4().hex, garment=garment_arrays(setup), body_path=body_path,
                   clips=sorted({n for s in segments for n in s.clip_names}), fps=float(setup.cfg["fps"]),
                   teacher=teacher)
    state = _state(context)
    paths = [cache_entry(state["garment"], state["body"], segment_clip(state["clips"], s), np.array(s.beta),
                         np.array(s.material), s.frames, cache_dir=cache_dir, teacher=teacher)[0] for s in segments]
    missing = [k for k, p in enumerate(paths) if not p.is_file()]
    simulated = {}                      # segment → CPU s, for those that came back (not past the deadline)

    def record(k, cpu, cache_hit):
        seg = segments[k]
        if log is not None:
            log({"segment": k, "clip": seg.clip, "variant": seg.variant, "start": seg.start,
                 "frames": seg.frames, "cpu_s": round(cpu, 2), "cache_hit": cache_hit})

    def arrived(i, result):
        if result is None:              # not started before the deadline
            return
        positions, summary, cpu = result
        write_cached(paths[missing[i]], positions, summary)
        simulated[missing[i]] = cpu
        record(missing[i], cpu, False)

    to_simulate = set(missing)
    for k in range(len(segments)):
        if k not in to_simulate:
            record(k, 0.0, True)
    runner.map(_simulate_segment, context, [segments[k] for k in missing], deadline, on_result=arrived)
    done = [(seg, str(path)) for k, (seg, path) in enumerate(zip(segments, paths))
            if k not in to_simulate or k in simulated]
    return done, float(sum(simulated.values()))


# ---- targets ----------------------------------------------------------------------------------------------------
def unskin(A, x):
    """Rest-frame positions v with A[..., :3] v + A[..., 3] = x (per vertex; A [T, N, 3, 4], x [T, N, 3])."""
    return np.linalg.solve(A[..., :3], (x - A[..., 3])[..., None])[..., 0]


def blend_matrices(setup, M):
    """Per-vertex LBS transforms A_i = Σ_k w_ik M_k [T, N, 3, 4] from joint skinning matrices M [T, J, 3, 4]."""
    return np.einsum("nk,wnkab->wnab", setup.skin_weights, np.asarray(M, np.float64)[:, setup.skin_indices])


def joint_matrices(setup, clip, beta, frames=None):
    """Joint skinning matrices M [T, J, 3, 4] (rest → world) of the first `frames` frames of a Clip at β."""
    from pleat import reference
    T = clip.num_frames if frames is None else frames
    return reference.pose_features(setup.parents, setup.joints_of(beta), setup.input_joints,
                                   np.asarray(clip.local_rotations[:T], np.float64),
                                   np.asarray(clip.root_translation[:T], np.float64),
                                   np.asarray(clip.root_rotation[:T], np.float64))["skin_matrices"]


def sequence(setup, clip, beta, material, positions=None):
    """One training sequence from a simulated clip: X_c rows [T, I] (latent block zero; row t predicts frame t
    from a reset at frame 0, as the runtime does), the joint skinning matrices M [T, J, 3, 4] and β (so garment and
    body can be posed again: pleat.train.contact, blend_matrices) and, given the simulated positions [T, N, 3], the
    rest-frame displacement targets [T, N, 3]. Only the garment's kinematics are computed (no body posing)."""
    from pleat import reference
    T = clip.num_frames if positions is None else min(len(positions), clip.num_frames)
    q = np.asarray(clip.local_rotations[:T], np.float64)
    tr = np.asarray(clip.root_translation[:T], np.float64)
    rq = np.asarray(clip.root_rotation[:T], np.float64)
    dt = np.full(T, 1.0 / float(clip.fps))
    M = joint_matrices(setup, clip, beta, T)
    static = reference.assemble_inputs(setup.asset_stub, q, tr, rq, dt, beta, material)
    s = {"static": static.astype(np.float64), "M": M, "beta": np.asarray(beta, np.float64)}
    if positions is not None:
        disp = unskin(blend_matrices(setup, M), np.asarray(positions[:T], np.float64)) - setup.shaped(beta)[None]
        disp[:, setup.pinned] = 0.0
        s["disp"] = disp
    return s


def load_sequences(setup, done, clips_by_name):
    """Training sequences for finished segments [(segment, cache path)]."""
    seqs = []
    for seg, path in done:
        clip = segment_clip(clips_by_name, seg)
        with np.load(path, allow_pickle=False) as z:
            positions = z["positions"]
        seqs.append(sequence(setup, clip, np.array(seg.beta), np.array(seg.material), positions))
    return seqs
