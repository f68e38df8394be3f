"""pleat-stability: where learned cloth fails — long runs, fast motion, unusual bodies, frame-time jitter,
interpenetration (docs/stability.md).

    pleat-stability --asset A.pleat [--quick] --out DIR [--motion CLIP ...] [--ref-window-s S]

Every case runs the asset and its LBS-only twin (same garment, zero network) through the C runtime. What is measured:
  deviation   mean per-vertex distance between Pleat and the LBS-only twin (mm) — the network's own displacement, which
              the runtime can compute for any length of run. Drift shows up as this (and the latent norm) growing.
  bound       pleat.eval.bounds.displacement_bound_m: the largest displacement the asset's decoder can ever produce
              (interval arithmetic over the guarded latent box); every vertex must stay within it.
  error       distance to the reference simulator (mm) — only in short windows (start and end of the long run,
              1× and 3× speed, β0 = ±3), because the reference costs seconds per frame here (a 10-minute
              reference would take days on this machine).
  penetration share of garment vertices inside the posed body (%) and the deepest (mm), per frame.

(a) long: 10 minutes at 30 fps (18,000 frames; --quick: 5,000) of chained clips (pleat.motion.concatenate, 0.25 s
    blends). The chain is a loop of clips repeated, cut so that its last `window` frames replay its first `window`
    frames' motion; drift ratio = deviation over the last window / deviation over the first (same motion, so any
    difference is accumulated state), drift slope = least-squares slope of the per-second deviation (mm/min).
(b) fast: each clip at 1×, 2× and 3× speed.
(c) bodies: β = ±3 on each of the first components, and ±4 (the clamp range; beyond training's ±3).
(d) dt jitter: dt drawn uniformly from [1/120, 1/15] s, the poses sampled at the jittered times.
(e) interpenetration: per-frame penetration of Pleat, LBS and (in the reference windows) the reference.
"""
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from pleat.cli import add_quiet, command, doc_parser
from pleat.eval import bounds
from pleat.fileio import finish_figure, write_text
from pleat.eval import metrics
from pleat.eval import scene as S

LONG_SECONDS = 600.0
DRIFT_WINDOW = 500
BLEND_S = 0.25
DEFAULT_CLIPS = ("deepmimic_pybullet/humanoid3d_walk", "deepmimic_pybullet/humanoid3d_run",
                 "deepmimic_pybullet/humanoid3d_jump", "deepmimic_pybullet/humanoid3d_punch",
                 "deepmimic_github/humanoid3d_jog", "deepmimic_pybullet/humanoid3d_kick")


# ---- motions ------------------------------------------------------------------------------------------------------
def replay_offset(fps, blend_s=BLEND_S):
    """First frame of the drift's first window: the frames before it have no blended twin at the chain's end."""
    return max(1, int(round(blend_s * fps)))


def chained_clip(clips, frames, window=DRIFT_WINDOW, blend_s=BLEND_S):
    """clips chained in a loop to at least `frames` frames, cut so that its last `window` frames replay frames
    [replay_offset, replay_offset + window) of the chain (same local rotations; the root path differs, which the
    network never sees since X_c is expressed in the heading frame)."""
    from pleat.motion import concatenate
    loop = clips[0]
    for c in clips[1:]:
        loop = concatenate(loop, c, blend_s)
    n = replay_offset(loop.fps, blend_s)
    unit = loop
    while loop.num_frames <= window + 2 * n + 2:            # short clips: the loop is repeated
        loop = concatenate(loop, unit, blend_s)
    chain = loop
    while chain.num_frames < frames - window:
        chain = concatenate(chain, loop, blend_s)
    # concatenate(a, b) ends with b[n:], so a head of window + n frames ends the chain with loop[n : n + window]
    chain = concatenate(chain, _cut(loop, window + n), blend_s)
    return replace(chain, name=f"chain[{len(clips)} clips]x{chain.num_frames}")


def looped(clip, frames, blend_s=BLEND_S):
    """The clip chained to itself (blended) until it has at least `frames` frames (DeepMimic clips are 1–3 s)."""
    from pleat.motion import concatenate
    out = clip
    while out.num_frames < frames:
        out = concatenate(out, clip, blend_s)
    return replace(out, name=clip.name)


def _cut(clip, n, start=0):
    return clip.frames_at(slice(start, start + n))


def jittered_motion(clip, seed=0, dt_range=(1 / 120, 1 / 15)):
    """Poses of `clip` at times advanced by dt ~ U(dt_range); returns (rotations, root_translation, root_rotation,
    dt [T]); the first dt is the first step's (the runtime's first-frame rule)."""
    rng = np.random.default_rng(seed)
    dts = rng.uniform(*dt_range, size=int(clip.duration / np.mean(dt_range)) + 2)
    times = np.concatenate([[0.0], np.cumsum(dts)])
    keep = times <= clip.duration
    times, dts = times[keep], np.concatenate([[dts[0]], dts])[keep]
    rot, tr, rr = clip.sample(times)
    return rot, tr, rr, dts


# ---- runs ---------------------------------------------------------------------------------------------------------
def deviation_mm(pleat_positions, lbs_positions):
    return np.linalg.norm(np.asarray(pleat_positions, np.float64) - lbs_positions, axis=-1) * 1000.0


def paired_run(ctx, data, lbs_data, weights, rotations, root_translation, root_rotation, dt_s, beta=None,
               material=None):
    """Pleat and LBS-only through the runtime on the same motion; per-frame deviation and guard statistics."""
    p = S.rollout(ctx, data, rotations, root_translation, root_rotation, dt_s, beta, material)
    q = S.rollout(ctx, lbs_data, rotations, root_translation, root_rotation, dt_s, beta, material)
    dev = deviation_mm(p.positions, q.positions)                    # [T, N]
    bound_mm = bounds.displacement_bound_m(weights) * 1000.0
    return dict(pleat=p, lbs=q, deviation_mm=dev.mean(1), deviation_max_mm=float(dev.max()),
                bound_excess_mm=float((dev - bound_mm[None]).max()), finite=bool(np.isfinite(p.positions).all()),
                resets=p.resets, latent_in_range=bool(
                    np.all(p.latent_min >= np.asarray(weights["z_min"], np.float32) - 1e-6)
                    and np.all(p.latent_max <= np.asarray(weights["z_max"], np.float32) + 1e-6)))


def drift(deviation_per_frame, fps, window=DRIFT_WINDOW, first_start=None):
    """Drift of the deviation over a chained_clip run: the last `window` frames against the frames they replay
    (starting at replay_offset), and the least-squares slope of the per-second mean (mm per minute)."""
    d = np.asarray(deviation_per_frame, np.float64)
    s = replay_offset(fps) if first_start is None else first_start
    first, last = d[s:s + window].mean(), d[-window:].mean()
    per_s = d[: len(d) // int(fps) * int(fps)].reshape(-1, int(fps)).mean(1)
    slope = np.polyfit(np.arange(len(per_s)) / 60.0, per_s, 1)[0] if len(per_s) > 1 else 0.0
    return dict(first_window_mm=float(first), last_window_mm=float(last),
                ratio=float(last / first) if first > 0 else (1.0 if last == 0 else float("inf")),
                slope_mm_per_min=float(slope), window=window, first_start=int(s))


def _summary(run):
    return dict(deviation_mean_mm=float(np.mean(run["deviation_mm"])), deviation_max_mm=run["deviation_max_mm"],
                bound_excess_mm=run["bound_excess_mm"], finite=run["finite"], numeric_resets=run["resets"],
                latent_in_range=run["latent_in_range"], latent_norm_max=float(run["pleat"].latent_norm.max()))


def _penetration(body, weights, clip, beta, positions, frames):
    bv, _ = S.posed_body(body, _select(clip, frames), beta)
    return metrics.penetration(S.signed_distances(bv, body.faces, positions[frames], S.collision_mask(weights, body)))


def _select(clip, frames):
    return clip.frames_at(frames)


def _motion(clip, weights):
    return S.clip_rotations_for(clip, weights["joint_names"]), clip.root_translation, clip.root_rotation


def _reference_window(body, weights, clip, start, frames, beta, material, progress):
    """Error of Pleat and LBS against the reference on clip[start:start+frames], all three started fresh there
    (the runtime restarted at the window's first pose too, so this checks accuracy, not carried state)."""
    from pleat.eval.reference import cached_simulate
    from pleat import runtime
    sub = _cut(clip, frames, start)
    garment = S.garment_from_asset(weights)
    ref, info = cached_simulate(garment, body, sub, beta, material, frames, progress=progress)
    return ref, sub, info


def _reference_case(ctx, body, data, lbs_data, weights, clip, frames, beta, material, progress):
    """Pleat and LBS (both started fresh) against the reference on the first `frames` frames of `clip`: mean vertex
    error and penetration of all three."""
    ref, sub, info = _reference_window(body, weights, clip, 0, frames, beta, material, progress)
    r = paired_run(ctx, data, lbs_data, weights, *_motion(sub, weights), 1.0 / S.EVAL_FPS, beta, material)
    out = dict(frames=int(frames), reference_seconds_per_frame=info["summary"].get("seconds_per_frame"),
               pleat_error_mm=float(metrics.vertex_error_mm(r["pleat"].positions, ref).mean()),
               lbs_error_mm=float(metrics.vertex_error_mm(r["lbs"].positions, ref).mean()))
    for k, x in (("pleat", r["pleat"].positions), ("lbs", r["lbs"].positions), ("reference", ref)):
        pen = _penetration(body, weights, sub, beta, x, np.arange(frames))
        out[f"{k}_penetration_pct"], out[f"{k}_max_depth_mm"] = pen["penetration_pct"], pen["max_depth_mm"]
    return out


# ---- the suite ----------------------------------------------------------------------------------------------------
def run_suite(asset_path, out_dir, quick=False, motions=DEFAULT_CLIPS, ref_window_s=None, progress=True,
              log=print, plot_prefix=""):
    from pleat import runtime
    from pleat.body import BodyModel
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    data, weights = S.read_weights(asset_path)
    lbs_data = S.lbs_only_bytes(weights)
    body = BodyModel.load()
    matches_body = S.skeleton_mismatch_mm(weights, body) < 1.0
    clips = [S.load_motion(m, body) for m in motions]
    loops = [looped(c, 300) for c in clips]                 # ≥ 10 s each for (b)–(d)
    fps = S.EVAL_FPS
    B = len(weights["shape_blend"])
    beta0 = np.zeros(B)
    material = np.asarray(weights["material_default"], np.float64)
    ref_window_s = (1.0 if quick else 10.0) if ref_window_s is None else ref_window_s
    ref_frames = int(round(ref_window_s * fps))
    report = dict(asset=str(asset_path), garment=str(weights.get("garment_name")),
                  model="lbs-only" if S.is_lbs_only(weights) else "network", quick=quick,
                  vertices=int(len(weights["template"])), clips=[c.name for c in clips],
                  displacement_bound_max_mm=float(bounds.displacement_bound_m(weights).max() * 1000.0),
                  reference_window_frames=ref_frames if matches_body else 0)
    series = {}
    t_start = time.perf_counter()
    with runtime.Context() as ctx:
        # (a) long run
        frames = 5000 if quick else int(LONG_SECONDS * fps)
        chain = chained_clip(clips, frames)
        run = paired_run(ctx, data, lbs_data, weights, *_motion(chain, weights), 1.0 / fps, beta0, material)
        long = dict(frames=chain.num_frames, seconds=chain.num_frames / fps, **_summary(run),
                    drift=drift(run["deviation_mm"], fps))
        series["long"] = dict(deviation_mm=run["deviation_mm"], latent_norm=run["pleat"].latent_norm)
        # (e) penetration along the long run, every 10th frame of the first and last minute (quick: 20 s)
        if matches_body:
            span = int((20 if quick else 60) * fps)
            idx = np.concatenate([np.arange(0, span, 10), np.arange(chain.num_frames - span, chain.num_frames, 10)])
            pen = {k: _penetration(body, weights, chain, beta0, run[k].positions, idx) for k in ("pleat", "lbs")}
            series["penetration"] = dict(frames=idx, **{k: np.asarray(v["per_frame_pct"]) for k, v in pen.items()})
            long["penetration"] = {k: dict(penetration_pct=v["penetration_pct"], max_depth_mm=v["max_depth_mm"])
                                   for k, v in pen.items()}
        # reference windows: the first and last `ref_frames` of the chain
        if matches_body and ref_frames > 1:
            windows = {}
            for name, start in (("first", 0), ("last", chain.num_frames - ref_frames)):
                ref, sub, info = _reference_window(body, weights, chain, start, ref_frames, beta0, material,
                                                   progress)
                fresh = paired_run(ctx, data, lbs_data, weights, *_motion(sub, weights), 1.0 / fps, beta0,
                                   material)
                carried = {k: run[k].positions[start:start + ref_frames] for k in ("pleat", "lbs")}
                ref_pen = _penetration(body, weights, sub, beta0, ref, np.arange(ref_frames))
                windows[name] = dict(
                    start_frame=int(start), frames=ref_frames,
                    pleat_error_mm=float(metrics.vertex_error_mm(carried["pleat"], ref).mean()),
                    pleat_fresh_error_mm=float(metrics.vertex_error_mm(fresh["pleat"].positions, ref).mean()),
                    lbs_error_mm=float(metrics.vertex_error_mm(carried["lbs"], ref).mean()),
                    reference_penetration_pct=ref_pen["penetration_pct"],
                    reference_max_depth_mm=ref_pen["max_depth_mm"],
                    reference_seconds_per_frame=info["summary"].get("seconds_per_frame"))
            long["reference_windows"] = windows
        report["long"] = long
        log(f"(a) long run: {long['frames']} frames, drift ratio {long['drift']['ratio']:.3f}")

        # (b) fast motion
        fast = {}
        series["fast"] = {}
        for c in loops[: (2 if quick else len(loops))]:
            for f in (1.0, 2.0, 3.0):
                cc = c.time_scaled(f) if f != 1.0 else c
                r = paired_run(ctx, data, lbs_data, weights, *_motion(cc, weights), 1.0 / fps, beta0, material)
                fast[cc.name] = dict(speed=f, frames=cc.num_frames, **_summary(r))
                series["fast"][cc.name] = r["deviation_mm"]
        report["fast"] = fast
        # errors against the reference in a short window at 1× and 3× (the reference is the slow part)
        if matches_body and ref_frames > 1:
            report["fast_reference"] = {
                f"{loops[0].name} {f:g}×": dict(speed=f, **_reference_case(
                    ctx, body, data, lbs_data, weights, loops[0].time_scaled(f) if f != 1.0 else loops[0],
                    ref_frames, beta0, material, progress)) for f in (1.0, 3.0)}
        log(f"(b) fast motion: {len(fast)} runs")

        # (c) unusual bodies
        bodies = {}
        c = loops[0]
        comps = range(2 if quick else min(B, 4))
        cases = [(k, v) for k in comps for v in (-3.0, 3.0, -4.0, 4.0)]
        pen_idx = np.arange(0, c.num_frames, max(1, c.num_frames // 15))
        for k, v in cases:
            beta = beta0.copy()
            beta[k] = v
            r = paired_run(ctx, data, lbs_data, weights, *_motion(c, weights), 1.0 / fps, beta, material)
            entry = dict(component=k, value=v, **_summary(r))
            if matches_body:
                for m in ("pleat", "lbs"):
                    p = _penetration(body, weights, c, beta, r[m].positions, pen_idx)
                    entry[f"{m}_penetration_pct"] = p["penetration_pct"]
                    entry[f"{m}_max_depth_mm"] = p["max_depth_mm"]
            bodies[f"beta{k}={v:+g}"] = entry
        report["bodies"] = bodies
        if matches_body and ref_frames > 1:
            report["bodies_reference"] = {}
            for v in (-3.0, 3.0):
                beta = beta0.copy()
                beta[0] = v
                report["bodies_reference"][f"beta0={v:+g}"] = _reference_case(
                    ctx, body, data, lbs_data, weights, c, ref_frames, beta, material, progress)
        log(f"(c) unusual bodies: {len(bodies)} runs")

        # (d) dt jitter
        jit = {}
        series["dt"] = {}
        for c in loops[: (2 if quick else 3)]:
            rot, tr, rr, dts = jittered_motion(c, seed=1)
            r = paired_run(ctx, data, lbs_data, weights, S.clip_rotations_for(
                replace(c, local_rotations=rot, root_translation=tr, root_rotation=rr),
                weights["joint_names"]), tr, rr, dts, beta0, material)
            clamped = int(sum(x == 1 for x in r["pleat"].results))
            jit[c.name] = dict(frames=len(dts), dt_min_s=float(dts.min()), dt_max_s=float(dts.max()),
                               clamped_steps=clamped, **_summary(r))
            series["dt"][c.name] = dict(dt=dts, deviation_mm=r["deviation_mm"])
        report["dt_jitter"] = jit
        log(f"(d) dt jitter: {len(jit)} runs")
    report["wall_s"] = time.perf_counter() - t_start
    images = out_dir / "images"
    images.mkdir(parents=True, exist_ok=True)
    report["plots"] = [str(p.relative_to(out_dir)) for p in plot_suite(report, series, images, plot_prefix)]
    return report


def plot_suite(report, series, out_dir, prefix=""):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    tag = f"{report['garment']} ({report['model']})"
    paths = []
    fps = S.EVAL_FPS
    fig, ax = plt.subplots(2, 1, figsize=(7, 4.5), sharex=True)
    t = np.arange(len(series["long"]["deviation_mm"])) / fps / 60.0
    ax[0].plot(t, series["long"]["deviation_mm"], lw=0.5)
    ax[0].set_ylabel("Pleat − LBS (mm)")
    ax[1].plot(t, series["long"]["latent_norm"], lw=0.5, color="tab:orange")
    ax[1].set_ylabel("‖latent‖")
    ax[1].set_xlabel("time (min)")
    d = report["long"]["drift"]
    ax[0].set_title(f"(a) long run, {tag}: drift ratio {d['ratio']:.3f}, slope {d['slope_mm_per_min']:.4f} mm/min",
                    fontsize=9)
    paths.append(finish_figure(fig, out_dir / f"stability_{prefix}long.png", dpi=80))

    fig, ax = plt.subplots(figsize=(7, 3.2))
    for name, dev in series["fast"].items():
        ax.plot(np.arange(len(dev)) / fps, dev, lw=0.8, label=name)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("Pleat − LBS (mm)")
    ax.set_title(f"(b) fast motion, {tag}", fontsize=9)
    ax.legend(fontsize=6, ncol=2)
    paths.append(finish_figure(fig, out_dir / f"stability_{prefix}fast.png", dpi=80))

    fig, ax = plt.subplots(figsize=(7, 3.2))
    names = list(report["bodies"])
    x = np.arange(len(names))
    if "pleat_penetration_pct" in next(iter(report["bodies"].values())):
        ax.bar(x - 0.2, [report["bodies"][n]["pleat_penetration_pct"] for n in names], 0.4, label="Pleat")
        ax.bar(x + 0.2, [report["bodies"][n]["lbs_penetration_pct"] for n in names], 0.4, label="LBS-only")
        ax.set_ylabel("vertices inside body (%)")
    else:
        ax.bar(x, [report["bodies"][n]["deviation_max_mm"] for n in names], 0.6, label="Pleat − LBS max")
        ax.set_ylabel("max deviation (mm)")
    ax.set_xticks(x, names, rotation=60, fontsize=6)
    ax.set_title(f"(c) unusual bodies, {tag}", fontsize=9)
    ax.legend(fontsize=7)
    paths.append(finish_figure(fig, out_dir / f"stability_{prefix}bodies.png", dpi=80))

    fig, ax = plt.subplots(2, 1, figsize=(7, 4), sharex=True)
    for name, s in series["dt"].items():
        tt = np.cumsum(s["dt"])
        ax[0].plot(tt, s["dt"] * 1000, lw=0.5, label=name)
        ax[1].plot(tt, s["deviation_mm"], lw=0.8)
    ax[0].set_ylabel("dt (ms)")
    ax[1].set_ylabel("Pleat − LBS (mm)")
    ax[1].set_xlabel("time (s)")
    ax[0].set_title(f"(d) frame-time jitter, {tag}", fontsize=9)
    ax[0].legend(fontsize=6)
    paths.append(finish_figure(fig, out_dir / f"stability_{prefix}dt.png", dpi=80))

    if "penetration" not in series:
        return paths
    fig, ax = plt.subplots(figsize=(7, 3))
    p = series["penetration"]
    half = len(p["frames"]) // 2
    for k in ("pleat", "lbs"):
        ax.plot(np.arange(len(p["frames"])), p[k], ".-", lw=0.6, ms=2, label=k)
    ax.axvline(half - 0.5, color="k", lw=0.5)
    ax.set_xlabel("sampled frame (every 10th; left: start of the long run, right: its end)")
    ax.set_ylabel("inside body (%)")
    ax.set_title(f"(e) interpenetration along the long run, {tag}", fontsize=9)
    ax.legend(fontsize=7)
    paths.append(finish_figure(fig, out_dir / f"stability_{prefix}penetration.png", dpi=80))
    return paths


def _f(v, d=2):
    return "—" if v is None else (f"{v:.{d}f}" if isinstance(v, float) else str(v))


def write_markdown(reports, path, command):
    """docs/stability.md from suite reports: definitions, numbers, plots, the command. One asset: its sections here;
    several: a row each here and each asset's sections on its own page beside it (stability-NAME.md)."""
    r0 = reports[0]
    lines = [
        "# Stability suite", "",
        f"Made by `{command}` (tools/pleat/eval/stability.py) — rerun it to refresh this page"
        f"{' (quick mode)' if r0['quick'] else ''}.", "",
        "What is measured (per frame, through the C runtime): **deviation** = mean distance between Pleat and its "
        "LBS-only twin (the network's own displacement; the runtime can afford it for any length); **bound** = the "
        "largest displacement the asset's decoder can produce for any latent the guard lets through (interval "
        "arithmetic, `pleat.eval.bounds`; a guarantee, and a loose one) — `bound excess` ≤ 0 means every vertex "
        "stayed inside it; **error** = distance to the reference simulator, only in short windows (the start and "
        "end of the long run, the first clip at 1× and 3× speed, β0 = ±3), because the reference costs a CPU "
        "core 0.2–0.5 s per frame for the 1k t-shirt and 1.2–1.6 s for the 4.4k one (docs/simulator.md), plus a "
        "20-frame lead-in per window, so a 10-minute reference would take hours; **penetration** = share of garment vertices inside "
        "the posed body and the deepest, from the simulator's collider (nearest body vertex + normal; pinned "
        "vertices included). Reference, error and penetration need an asset built on assets/body.npz; an asset "
        "on another skeleton (the random-weight golden tube) gets the runtime-only numbers.", ""]
    if len(reports) == 1:
        lines += _markdown_section(reports[0])
    else:       # one row per asset here, each asset's sections on a page of its own beside this one
        lines += ["## Every garment", "",
                  "One row per asset; the numbers are explained on each asset's own page. Errors are against the "
                  "reference simulator, Pleat's first and LBS-only's second (`n/a`: no reference for that asset).",
                  ""]
        lines += _table(["asset", "N", "drift ratio (long run)", "end of long run: error (mm)",
                         "3× speed: error (mm)", "β0 = ±3, worst: error (mm)", "penetration, long run (%)",
                         "finite, no resets, latent in range (every run)", "worst bound excess (mm)"],
                        (_summary_row(r, path) for r in reports))
        lines += [""]
        for r in reports:
            write_text(Path(path).parent / _page_name(r, path), "\n".join(
                [f"# Stability: `{r['asset']}`", "",
                 f"Part of [{Path(path).name}]({Path(path).name}) (made by the same command, which says what each "
                 "quantity is).", ""] + _markdown_section(r)[2:]))
    lines += ["## The same checks as tests", "",
              "`tests/python/test_stability_runtime.py` runs small versions in the default test command (a 300-vertex "
              "random-weight asset with a contractive latent recurrence, random smooth motion): a 5,000-frame chained "
              "run whose last 500 frames replay frames 8–507 must have deviation ratio ≤ 1.2 and |slope| < 5 % of the "
              "first window per minute; every run (long, 2× and 3× speed, β = ±3/±4, dt jitter) must stay finite, "
              "reset nothing, keep the latent inside [z_min, z_max] and every vertex inside the decoder bound; "
              "β beyond the range equals β at the range; dt above dt_max equals dt_max; a NaN pose or dt is "
              "rejected and leaves the instance as it was; an overflow inside f_LP returns NUMERIC_RESET and equals "
              "a fresh first frame.", "",
              "`tests/python/test_stability_shipped.py` runs every shipped trained asset (`assets/*.pleat`) on "
              "real motion capture (walk, run, jump, punch): a 5,000-frame chain must have deviation ratio ≤ 1.2, "
              "stay finite, reset nothing and keep the latent in range; the run played 3× faster and bodies at "
              "β0 = ±4 and β1 = +4 must stay finite, and no vertex of any of these runs may be more than 300 mm from "
              "the skinned garment (the t-shirt tiers measured 87–168 mm at worst; the simulator's own t-shirt is more "
              "than 150 mm from the skinned one in 27 % of its training frames, more than 300 mm in 6 %) — 1.0 m for "
              "the dress, whose simulated skirt is more than 700 mm from the skinned one in 6.5 % of its training "
              "frames (its model: 630 mm at worst).", ""]
    write_text(path, "\n".join(lines))


def _page_name(r, path):
    """The page of one asset's sections beside the summary page: stability.md → stability-dress.md."""
    return f"{Path(path).stem}-{Path(str(r['asset']).replace('tier:', 'tier_')).stem}.md"


def _pair(a, b):
    return f"{_f(a)} / {_f(b)}"


def _summary_row(r, path):
    """The summary table's cells for one asset's report (write_markdown with several assets)."""
    lg = r["long"]
    window = (lg.get("reference_windows") or {}).get("last")
    fast = next((v for v in (r.get("fast_reference") or {}).values() if v["speed"] == 3.0), None)
    bodies = list((r.get("bodies_reference") or {}).values())
    worst = max(bodies, key=lambda v: v["pleat_error_mm"] / max(v["lbs_error_mm"], 1e-9)) if bodies else None
    pen = lg.get("penetration") or {}
    runs = [lg] + [v for part in ("fast", "bodies", "dt_jitter") for v in r[part].values()]
    healthy = all(v["finite"] and v["numeric_resets"] == 0 for v in runs) and lg["latent_in_range"]
    excess = max(v["bound_excess_mm"] for v in runs)
    na = "n/a"
    return [f"[`{r['asset']}`]({_page_name(r, path)})", r["vertices"], _f(lg["drift"]["ratio"], 4),
            _pair(window["pleat_error_mm"], window["lbs_error_mm"]) if window else na,
            _pair(fast["pleat_error_mm"], fast["lbs_error_mm"]) if fast else na,
            _pair(worst["pleat_error_mm"], worst["lbs_error_mm"]) if worst else na,
            _pair((pen.get("pleat") or {}).get("penetration_pct"), (pen.get("lbs") or {}).get("penetration_pct"))
            if pen else na, "yes" if healthy else "**no**", _f(excess, 1)]


def _markdown_section(r):
    pre = r.get("plot_prefix", "")
    lg = r["long"]
    d = lg["drift"]
    lines = [
        f"## Asset `{r['asset']}`", "",
        f"Garment `{r['garment']}`, {r['vertices']} vertices, model **{r['model']}**"
        + (" — the network outputs zero, so Pleat equals the LBS-only baseline by construction: every Pleat − LBS "
           "number is 0 and this section checks the pipeline, the guards, the LBS baseline's error and penetration"
           if r["model"] == "lbs-only" else "")
        + f". Decoder bound {r['displacement_bound_max_mm']:.1f} mm at the worst vertex. Wall time "
        f"{r['wall_s']:.0f} s.", "",
        "### (a) Long run", "",
        f"{lg['frames']} frames ({lg['seconds'] / 60:.1f} min at 30 fps) of chained clips "
        f"({', '.join('`' + c + '`' for c in r['clips'])}, 0.25 s blended transitions), looped so that the last "
        f"{d['window']} frames replay frames {d['first_start']}–{d['first_start'] + d['window'] - 1}.", "",
    ]
    quantities = [
        ("deviation, first window (mm)", _f(d["first_window_mm"], 3)),
        ("deviation, last window (mm)", _f(d["last_window_mm"], 3)),
        ("drift ratio last / first", _f(d["ratio"], 4)),
        ("drift slope (mm / min)", _f(d["slope_mm_per_min"], 5)),
        ("max latent norm", _f(lg["latent_norm_max"], 3)),
        ("bound excess (mm, < 0 = inside)", _f(lg["bound_excess_mm"], 1)),
        ("all finite / numeric resets / latent in range",
         f"{lg['finite']} / {lg['numeric_resets']} / {lg['latent_in_range']}"),
    ] + [(f"{k}: penetration (%) / deepest (mm), sampled frames", _penetration_cell(v))
         for k, v in lg.get("penetration", {}).items()]
    lines += _table(["quantity", "value"], quantities)
    if "reference_windows" in lg:
        lines += ["", f"Reference windows ({r['reference_window_frames']} frames each; the reference starts at rest "
                  "at the window's first pose, Pleat and LBS carry their state from the long run):", ""]
        lines += _table(["window", "start frame", "Pleat error (mm)", "Pleat restarted (mm)", "LBS error (mm)",
                         "reference penetration (%) / deepest (mm)", "reference s/frame"],
                        ([name, w["start_frame"], _f(w["pleat_error_mm"]), _f(w["pleat_fresh_error_mm"]),
                          _f(w["lbs_error_mm"]), _penetration_cell(w, "reference_"),
                          _f(w["reference_seconds_per_frame"], 1)] for name, w in lg["reference_windows"].items()))
    lines += ["", "![long run](images/stability_{pre}long.png)", ""]
    if f"images/stability_{pre}penetration.png" in r["plots"]:
        lines += ["### (e) Interpenetration along the long run", "",
                  "![penetration](images/stability_{pre}penetration.png)", ""]
    lines += ["### (b) Fast motion", ""]
    lines += _table(["clip", "speed", "frames", "deviation mean / max (mm)", "bound excess (mm)", "finite", "resets"],
                    ([name, f"{v['speed']:g}×", v["frames"], _deviation_cell(v), _f(v["bound_excess_mm"], 1),
                      v["finite"], v["numeric_resets"]] for name, v in r["fast"].items()))
    lines += ["", "Each clip is looped to at least 10 s (300 frames at 1×) before it is sped up.", ""]
    lines += _reference_table(r.get("fast_reference"), "run")
    lines += [
              "![fast](images/stability_{pre}fast.png)", "", "### (c) Unusual bodies", "",
              f"β = ±3 (training's range) and ±4 (beyond it; the clamp limit) on one component at a time, clip "
              f"`{r['clips'][0]}` looped to ≥ 10 s; penetration on 15 frames spread evenly over the clip.", ""]
    lines += _table(["β", "deviation mean / max (mm)", "bound excess (mm)", "Pleat penetration (%) / deepest (mm)",
                     "LBS penetration (%) / deepest (mm)", "finite"],
                    ([name, _deviation_cell(v), _f(v["bound_excess_mm"], 1), _penetration_cell(v, "pleat_"),
                      _penetration_cell(v, "lbs_"), v["finite"]] for name, v in r["bodies"].items()))
    lines += [""] + _reference_table(r.get("bodies_reference"), "β")
    lines += ["![bodies](images/stability_{pre}bodies.png)", "", "### (d) Frame-time jitter", "",
              "dt drawn uniformly from [1/120, 1/15] s; the poses are the clip sampled at the jittered times.", ""]
    lines += _table(["clip", "steps", "dt range (ms)", "clamped steps", "deviation mean / max (mm)",
                     "bound excess (mm)", "finite", "resets"],
                    ([name, v["frames"], f"{v['dt_min_s'] * 1000:.1f}–{v['dt_max_s'] * 1000:.1f}", v["clamped_steps"],
                      _deviation_cell(v), _f(v["bound_excess_mm"], 1), v["finite"], v["numeric_resets"]]
                     for name, v in r["dt_jitter"].items()))
    lines += ["", "![dt jitter](images/stability_{pre}dt.png)", ""]
    return [ln.replace("{pre}", pre) for ln in lines]


def _table(head, rows):
    """A markdown table: the header cells, the rule, then one line per row of cells."""
    return (["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
            + ["| " + " | ".join(str(c) for c in row) + " |" for row in rows])


def _deviation_cell(v):
    return f"{_f(v['deviation_mean_mm'])} / {_f(v['deviation_max_mm'])}"


def _penetration_cell(v, who=""):
    """Penetration (%) / deepest (mm) of `who` ("pleat_", "lbs_", "reference_"; "" where the case holds one)."""
    return f"{_f(v.get(who + 'penetration_pct'))} / {_f(v.get(who + 'max_depth_mm'), 1)}"


def _reference_table(cases, what):
    if not cases:
        return []
    n = next(iter(cases.values()))["frames"]
    lines = [f"Against the reference simulator (first {n} frames; Pleat, LBS and the reference all start fresh "
             "there):", ""]
    lines += _table([what, "Pleat error (mm)", "LBS error (mm)", "penetration (%) / deepest (mm): Pleat", "LBS",
                     "reference", "reference s/frame"],
                    ([name, _f(v["pleat_error_mm"]), _f(v["lbs_error_mm"]), _penetration_cell(v, "pleat_"),
                      _penetration_cell(v, "lbs_"), _penetration_cell(v, "reference_"),
                      _f(v["reference_seconds_per_frame"], 1)] for name, v in cases.items()))
    return lines + [""]


def _prefix(i, asset):
    return "" if i == 0 else Path(str(asset).replace("tier:", "tier_")).stem + "_"


def build_parser():
    ap = doc_parser("pleat-stability", __doc__)
    ap.add_argument("--asset", required=True, nargs="+",
                    help="one or more assets (one section each); tier:NAME = random weights at a tier's sizes")
    ap.add_argument("--out", required=True, help="output folder (stability.md and the stability_*.png plots)")
    ap.add_argument("--quick", action="store_true", help="5,000-frame long run, fewer cases, 1 s reference windows")
    ap.add_argument("--motion", nargs="+", default=list(DEFAULT_CLIPS), help="clips of the long run and the cases")
    ap.add_argument("--ref-window-s", type=float, default=None,
                    help="reference window length at the start and end of the long run (0: none)")
    ap.add_argument("--json", default=None, help="also write the full report to this JSON file")
    return add_quiet(ap)


@command("pleat-stability")
def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)     # the report quotes the command line
    args = build_parser().parse_args(argv)
    import shlex
    reports = []
    for i, asset in enumerate(args.asset):
        reports.append(run_suite(asset, args.out, args.quick, args.motion, args.ref_window_s, not args.quiet,
                                 log=(lambda m: None) if args.quiet else (lambda m: print(m, file=sys.stderr)),
                                 plot_prefix=_prefix(i, asset)))
        reports[-1]["plot_prefix"] = _prefix(i, asset)
    cmdline = "pleat-stability " + " ".join(shlex.quote(a) for a in argv)
    write_markdown(reports, Path(args.out) / "stability.md", cmdline)
    if args.json:
        write_text(args.json, json.dumps(reports, indent=1))
    report = reports[0]
    short = dict(drift=report["long"]["drift"], long_finite=report["long"]["finite"],
                 worst_bound_excess_mm=max([report["long"]["bound_excess_mm"]] +
                                           [v["bound_excess_mm"] for part in ("fast", "bodies", "dt_jitter")
                                            for v in report[part].values()]),
                 wall_s=round(report["wall_s"], 1))
    print(json.dumps(short))
    return 0


if __name__ == "__main__":
    sys.exit(main())
