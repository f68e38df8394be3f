"""A sudden stop: does the garment keep moving and settle, as the simulated one does? (docs/accuracy.md, "Sudden stops")

    PLEAT_LIBRARY=build/eval/libpleat.so pleat-sudden-stop --asset A.pleat \
        [--motion deepmimic_github/humanoid3d_jog] [--move 20] [--hold 40] [--region skirt] \
        [--settle-threshold 0.01] --out out/stop.json [--plot stop.png]
    PLEAT_LIBRARY=build/eval/libpleat.so pleat-sudden-stop --asset A.pleat --probes [--probe-clips CLIP ...] \
        [--region skirt] --out out/stop_probes.json [--plot probes.png]

The body plays the first `--move` frames of a clip, then holds its last pose (root included) for `--hold` frames.
Pleat (the C runtime), LBS-only and the reference simulator are run on it; per frame the garment's mean vertex speed
relative to the body (m/s; the body is still after the stop, so this is the cloth's own motion), over the whole
garment or one region (pleat.eval.regions, e.g. the dress's skirt). A method that keeps the dynamics shows what the
reference shows: speed carried past the stop, decaying over a few tenths of a second; LBS-only stops dead.

The reference never quite comes to rest (its speed stays at a few mm/s for the whole hold: creep), so each method's
numbers are measured above its own late-hold floor — a garment that comes to rest is not punished for it:
  floor_m_s          median speed over the last 0.4 s of the hold
  follow_through_mm  ∫ max(0, speed − floor) dt over the first 0.5 s after the stop: the path the cloth travels
                     after the body stopped, beyond the floor (mm, mean over vertices)
  settle_s           time after the stop until speed − floor stays below --settle-threshold (samples at the middle of
                     their frame interval, the last crossing interpolated linearly; `settled` false if it never does)
and pleat's and LBS-only's ratios to the reference's. --probes runs four stop clips (run, walk, jump, punch), each
cut where the body moves fastest after its first 0.5 s (joint speed, median of 3 frames; not just after a one-frame
jump in the clip's pose) and held for --hold frames
(at least 1.3 s), and says for each whether pleat's follow-through and settle time are within ±30 % (--tolerance)
of the reference's. --reference-spread adds a second reference started 1 µm apart (as pleat-eval's) and scores it
against the first like a method (`reference_spread`, `spread_vs_reference`): how far two equally valid simulations'
follow-through and settle time are apart, the floor under which no method's ratio means anything.
"""
import json
import sys
from pathlib import Path

import numpy as np

from pleat.cli import UsageError, add_quiet, command, doc_parser
from pleat.fileio import finish_figure, write_text

DEFAULT_MOTION = "deepmimic_github/humanoid3d_jog"
DEFAULT_MOVE = 20
FLOOR_WINDOW_S = 0.4           # the late hold whose median speed is the floor
FOLLOW_THROUGH_WINDOW_S = 0.5
SETTLE_THRESHOLD_M_S = 0.01
PROBE_TOLERANCE = 0.3          # within ±30 % of the reference
# The probe set: stops from a run, a walk, a jump and a punch (training and validation clips, pleat-motion list)
PROBES = (("run", "deepmimic_pybullet/humanoid3d_run"), ("walk", "deepmimic_pybullet/humanoid3d_walk"),
          ("jump", "deepmimic_pybullet/humanoid3d_jump"), ("punch", "deepmimic_pybullet/humanoid3d_punch"))
PROBE_EARLIEST_CUT_S = 0.5     # the reference starts at rest: let the cloth get moving before the stop
PROBE_MIN_HOLD_S = 1.3         # long enough for the follow-through window and a separate late-hold floor
POSE_JUMP_RATIO = 1.3          # a one-frame jump: joint speed this many times both neighbours'
POSE_JUMP_CLEAR_S = 0.2        # no probe stop this soon after one


def stop_clip(clip, move, hold):
    idx = np.concatenate([np.arange(move), np.full(hold, move - 1)])
    return clip.frames_at(idx, name=f"{clip.name}_stop")


def speeds(positions, fps):
    """Mean vertex speed per frame [T − 1] (m/s): sample i is the mean |x(i+1) − x(i)| · fps."""
    p = np.asarray(positions, np.float64)
    return np.linalg.norm(np.diff(p, axis=0), axis=-1).mean(axis=1) * fps


def settle(speed, move, fps, threshold_m_s=0.01):
    """(mean speed over the first 0.2 s after the stop, seconds until the speed stays below threshold)."""
    after = speed[move - 1:]
    n = max(1, int(round(0.2 * fps)))
    above = np.nonzero(after > threshold_m_s)[0]
    return float(after[:n].mean()), float((above[-1] + 1) / fps) if len(above) else 0.0


# ---- follow-through above the late-hold floor ------------------------------------------------------------------
# speed[move − 1] is the first interval with the body still (frames move − 1 → move), so speed[move − 1:] is the
# hold; speed[move − 2] is the last interval the body moved.

def late_floor(speed, move, fps, window_s=FLOOR_WINDOW_S):
    """Median speed over the last window_s of the hold (m/s): the creep a series never loses."""
    after = np.asarray(speed, np.float64)[move - 1:]
    n = max(1, int(round(window_s * fps)))
    return float(np.median(after[-n:]))


def follow_through_mm(speed, move, fps, floor_m_s, window_s=FOLLOW_THROUGH_WINDOW_S):
    """∫ max(0, speed − floor) dt over the first window_s after the stop (mm). Each sample is the mean speed over
    its frame interval, so the sum is the mean distance the vertices travel beyond the floor."""
    after = np.asarray(speed, np.float64)[move - 1:]
    n = max(1, int(round(window_s * fps)))
    return float(np.maximum(0.0, after[:n] - floor_m_s).sum() / fps * 1000.0)


def settle_time(speed, move, fps, floor_m_s, threshold_m_s=SETTLE_THRESHOLD_M_S):
    """(seconds after the stop until speed − floor stays below threshold, whether it does within the hold).

    Samples sit at the middle of their frame interval (the first held one at 0.5/fps) and the last downward crossing
    is interpolated linearly between two samples, so the time is not rounded to whole frames (at 30 fps a frame is a
    third of a typical 0.1 s settle); 0 when the first interval after the stop is already below. The last interval
    the body moved is not used: the garment's speed there is the body's, not its own."""
    excess = np.asarray(speed, np.float64)[move - 1:] - floor_m_s
    t = (np.arange(len(excess)) + 0.5) / fps
    above = np.nonzero(excess > threshold_m_s)[0]
    if len(above) == 0:
        return 0.0, True
    k = int(above[-1])
    if k == len(excess) - 1:
        return float(len(excess) / fps), False           # still above at the end of the hold
    s = (excess[k] - threshold_m_s) / (excess[k] - excess[k + 1])
    return float(t[k] + s * (t[k + 1] - t[k])), True


def stop_metrics(speed, move, fps, threshold_m_s=SETTLE_THRESHOLD_M_S):
    """floor_m_s, follow_through_mm, settle_s and settled of one speed series (see the module docstring)."""
    floor = late_floor(speed, move, fps)
    t, settled = settle_time(speed, move, fps, floor, threshold_m_s)
    return {"floor_m_s": floor, "follow_through_mm": follow_through_mm(speed, move, fps, floor),
            "settle_s": t, "settled": settled}


def ratio(value, reference):
    """value / reference; 1 when both are 0 (both at rest at once), None when only the reference is 0."""
    if reference > 0:
        return float(value / reference)
    return 1.0 if value == 0 else None


def compare(method, reference, tolerance=PROBE_TOLERANCE):
    """A method's follow-through and settle time against the reference's: ratios and whether each is within
    ±tolerance (a ratio that cannot be formed is not within)."""
    out = {}
    for key, name in (("follow_through_mm", "follow_through"), ("settle_s", "settle")):
        r = ratio(method[key], reference[key])
        out[f"{name}_ratio"] = r
        out[f"{name}_within"] = r is not None and abs(r - 1.0) <= tolerance + 1e-12
    return out


# ---- running stops ---------------------------------------------------------------------------------------------

def pose_jumps(joint_speed, ratio=POSE_JUMP_RATIO):
    """Frame intervals whose joint speed is more than `ratio` times both neighbours': a one-frame jump in the pose
    (a clip's loop seam; the DeepMimic run and walk each have one), not motion."""
    s = np.asarray(joint_speed, np.float64)
    if len(s) < 3:
        return []
    inner = s[1:-1] > ratio * np.maximum(s[:-2], s[2:])
    return [int(j) + 1 for j in np.flatnonzero(inner)]


def fast_cut(clip, body, earliest_s=PROBE_EARLIEST_CUT_S):
    """(move frames, the body's mean joint speed in m/s over the last moving interval, the pose jumps avoided) for
    a stop where the body moves fastest after its first earliest_s. Speed: the mean world speed of the joints (root
    motion included) per frame interval, through a median of 3 so that a one-frame jump cannot be chosen; no cut
    within POSE_JUMP_CLEAR_S after a jump either (the cloth would still be jolting from it at the stop); among
    intervals whose median ties (a median always leaves one around a peak) the fastest, then the first."""
    G = body.forward_kinematics(clip.local_matrices(), clip.root_translation, clip.root_matrices())
    s = np.linalg.norm(np.diff(G[..., :3, 3], axis=0), axis=-1).mean(axis=1) * clip.fps     # [T − 1]
    if len(s) < 3:
        raise ValueError(f"{clip.name}: {clip.num_frames} frames are too few to choose a stop in")
    smooth = np.full(len(s), -np.inf)
    smooth[1:-1] = np.median(np.stack([s[:-2], s[1:-1], s[2:]]), axis=0)     # the ends have no full window
    jumps = pose_jumps(s)
    ok = np.zeros(len(s), bool)
    ok[min(max(1, int(round(earliest_s * clip.fps))), len(s) - 2):len(s) - 1] = True
    clear = ok.copy()
    for j in jumps:
        clear[j:j + int(round(POSE_JUMP_CLEAR_S * clip.fps)) + 1] = False
    if clear.any():
        ok = clear
    score = np.where(ok, smooth, -np.inf)
    best = score.max()
    candidates = np.flatnonzero(score >= best - 1e-9 * abs(best))
    i = int(candidates[np.argmax(s[candidates])])
    return i + 2, float(s[i]), jumps          # interval i (frame i → i + 1) is the last one the body moves


class _Scene:
    """The asset, its LBS-only twin, the body and the region mask, loaded once for any number of stops."""

    def __init__(self, asset, region=None):
        from pleat.body import BodyModel
        from pleat.eval import scene as S
        from pleat.eval.regions import garment_regions
        self.asset = str(asset)
        self.data, self.w = S.read_weights(asset)
        self.lbs_data = S.lbs_only_bytes(self.w)
        self.body = BodyModel.load(None)
        self.garment = S.garment_from_asset(self.w)
        self.beta = np.zeros(len(self.w["shape_blend"]))
        self.material = np.asarray(self.w["material_default"], np.float64)
        self.region = region
        self.mask = None
        if region is not None:
            regions = garment_regions(str(self.w.get("garment_name")), self.w["template"], self.w["faces"],
                                      self.body, self.w["skin_indices"], self.w["skin_weights"])
            if region not in regions:
                raise UsageError(f"--region {region!r}: the asset's garment ({self.w.get('garment_name')}) has "
                                 f"the regions {', '.join(regions)}")
            self.mask = regions[region]

    def load(self, motion):
        from pleat.eval import scene as S
        return S.load_motion(motion, self.body, S.EVAL_FPS, None)

    def stop(self, ctx, clip, move, hold, threshold_m_s, progress=False, spread=False):
        """The report of one stop: per method the speed series and its numbers, and the ratios to the reference
        (with `spread`, a second reference from a start moved by SPREAD_PERTURBATION_M is a method too)."""
        from pleat.eval import scene as S
        from pleat.eval.cli import SPREAD_PERTURBATION_M
        from pleat.eval.reference import cached_simulate
        clip = stop_clip(clip, move, hold)
        runs = {"pleat": S.clip_rollout(ctx, self.data, self.w, clip, self.beta, self.material).positions,
                "lbs": S.clip_rollout(ctx, self.lbs_data, self.w, clip, self.beta, self.material).positions}
        runs["reference"], _ = cached_simulate(self.garment, self.body, clip, self.beta, self.material,
                                               clip.num_frames, progress=progress)
        if spread:
            runs["reference_spread"], _ = cached_simulate(self.garment, self.body, clip, self.beta, self.material,
                                                          clip.num_frames, progress=progress,
                                                          start_perturbation_m=SPREAD_PERTURBATION_M)
        out = {"move_frames": move, "hold_frames": hold, "fps": clip.fps}
        for name in runs:
            p = runs[name] if self.mask is None else np.asarray(runs[name])[:, self.mask]
            v = speeds(p, clip.fps)
            first, t_settle = settle(v, move, clip.fps)
            out[name] = {"speed_m_s": v.tolist(), "mean_speed_first_0.2s_after_stop": first,
                         "settles_after_s": t_settle, "final_speed_m_s": float(v[-5:].mean()),
                         **stop_metrics(v, move, clip.fps, threshold_m_s)}
        return out

    def header(self, threshold_m_s):
        return {"asset": self.asset, "region": self.region or "all",
                "region_vertices": int(len(self.w["template"]) if self.mask is None else self.mask.sum()),
                "settle_threshold_m_s": threshold_m_s, "floor_window_s": FLOOR_WINDOW_S,
                "follow_through_window_s": FOLLOW_THROUGH_WINDOW_S}


def _with_ratios(rep, tolerance):
    rep["pleat_vs_reference"] = compare(rep["pleat"], rep["reference"], tolerance)
    rep["lbs_vs_reference"] = compare(rep["lbs"], rep["reference"], tolerance)
    if "reference_spread" in rep:
        rep["spread_vs_reference"] = compare(rep["reference_spread"], rep["reference"], tolerance)
    return rep


def run(asset, motion, move, hold, progress=False, region=None, threshold_m_s=SETTLE_THRESHOLD_M_S,
        tolerance=PROBE_TOLERANCE, spread=False):
    from pleat import runtime
    scene = _Scene(asset, region)
    clip = scene.load(motion)
    with runtime.Context() as ctx:
        rep = scene.stop(ctx, clip, move, hold, threshold_m_s, progress, spread)
    return _with_ratios({**scene.header(threshold_m_s), "motion": motion, **rep}, tolerance)


def probe_set(clips):
    """(name, clip) probes for clip names or files: a file by its stem, a clip by its last path part without the
    DeepMimic prefix (deepmimic_github/humanoid3d_jog → jog)."""
    return tuple((Path(c).stem if Path(c).suffix else c.split("/")[-1].removeprefix("humanoid3d_"), c) for c in clips)


def run_probes(asset, hold, progress=False, region=None, threshold_m_s=SETTLE_THRESHOLD_M_S,
               tolerance=PROBE_TOLERANCE, probes=PROBES, spread=False):
    """The probe set's report: one row per probe (its clip, cut and stop report) and how many are within."""
    from pleat import runtime
    scene = _Scene(asset, region)
    rows = []
    with runtime.Context() as ctx:
        for name, motion in probes:
            clip = scene.load(motion)
            move, body_speed, jumps = fast_cut(clip, scene.body)
            rep = scene.stop(ctx, clip, move, hold, threshold_m_s, progress, spread)
            rows.append(_with_ratios({"probe": name, "motion": motion, "cut_s": (move - 1) / clip.fps,
                                      "body_joint_speed_m_s": body_speed, "pose_jump_intervals": jumps, **rep},
                                     tolerance))
            if progress:
                print(f"{name}: stop after {move} frames", file=sys.stderr)
    within = {k: sum(r["pleat_vs_reference"][f"{k}_within"] for r in rows) for k in ("follow_through", "settle")}
    out = {**scene.header(threshold_m_s), "tolerance": tolerance, "probes": rows,
           "follow_through_within": within["follow_through"], "settle_within": within["settle"],
           "all_within": all(within[k] == len(rows) for k in within)}
    if spread:
        out["spread_within"] = {k: sum(r["spread_vs_reference"][f"{k}_within"] for r in rows)
                                for k in ("follow_through", "settle")}
    return out


def _plot_axes(ax, report, title):
    fps = report["fps"]
    start = max(0, report["move_frames"] - 6)        # the end of the motion and what follows, on a log scale
    for name in [n for n in ("reference", "reference_spread", "pleat", "lbs") if n in report]:
        v = np.maximum(np.asarray(report[name]["speed_m_s"]), 1e-5)
        ax.plot(np.arange(start + 1, len(v) + 1) / fps, v[start:], label=name, marker=".")
    ax.axvline((report["move_frames"] - 1) / fps, color="k", ls=":", lw=1)
    ax.set_yscale("log")
    ax.set_xlabel("time (s); dotted: the body stops")
    ax.set_title(title)


def plot(report, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rows = report.get("probes") or [report]
    fig, axes = plt.subplots(1, len(rows), figsize=(7 if len(rows) == 1 else 3.6 * len(rows), 3.4), squeeze=False)
    for ax, r in zip(axes[0], rows):
        _plot_axes(ax, r, f"sudden stop: {r.get('probe') or r['motion'].split('/')[-1]}")
    axes[0][0].set_ylabel("mean garment vertex speed (m/s, log)")
    axes[0][0].legend(fontsize=8)
    finish_figure(fig, path, dpi=90)


def build_parser():
    ap = doc_parser("pleat-sudden-stop", __doc__)
    ap.add_argument("--asset", required=True, help="the .pleat asset")
    ap.add_argument("--motion", default=None, help=f"clip name or file (default {DEFAULT_MOTION})")
    ap.add_argument("--move", type=int, default=None, help=f"frames of motion before the stop (default {DEFAULT_MOVE})")
    ap.add_argument("--hold", type=int, default=40, help="frames held after it")
    ap.add_argument("--probes", action="store_true",
                    help="run the probe set (run, walk, jump, punch, each cut where the body moves fastest) instead "
                         "of one --motion")
    ap.add_argument("--probe-clips", nargs="+", default=None, metavar="CLIP",
                    help="with --probes: these clips (names or files), each cut where the body moves fastest, instead "
                         "of the four (e.g. the validation clips, motion a model never trained on)")
    ap.add_argument("--region", default=None,
                    help="measure the speed over one garment region only (pleat.eval.regions; e.g. skirt)")
    ap.add_argument("--settle-threshold", type=float, default=SETTLE_THRESHOLD_M_S,
                    help="speed above the floor below which the garment counts as settled, m/s (default 0.01)")
    ap.add_argument("--tolerance", type=float, default=PROBE_TOLERANCE,
                    help="relative band around the reference's follow-through and settle time (default 0.3)")
    ap.add_argument("--reference-spread", action="store_true",
                    help="also a second reference started 1 µm apart, scored against the first like a method: how "
                         "far two valid simulations' follow-through and settle time are apart")
    ap.add_argument("--out", required=True, help="output file: the JSON report")
    ap.add_argument("--plot", default=None, help="output file: the speed plot (PNG)")
    return add_quiet(ap)


def _show(x):
    return "n/a" if x is None else f"{x:.2f}"


def _print_probes(rep):
    for r in rep["probes"]:
        p, ref, c = r["pleat"], r["reference"], r["pleat_vs_reference"]
        print(f"{r['probe']} (stop at {r['cut_s']:.2f} s, body {r['body_joint_speed_m_s']:.2f} m/s): "
              f"follow-through {p['follow_through_mm']:.1f} mm / reference {ref['follow_through_mm']:.1f} mm "
              f"(×{_show(c['follow_through_ratio'])}{'' if c['follow_through_within'] else ', outside'}), "
              f"settle {p['settle_s']:.2f} s / {ref['settle_s']:.2f} s "
              f"(×{_show(c['settle_ratio'])}{'' if c['settle_within'] else ', outside'})")
        if "spread_vs_reference" in r:
            s = r["spread_vs_reference"]
            print(f"  a second reference 1 µm apart: follow-through ×{_show(s['follow_through_ratio'])}, "
                  f"settle ×{_show(s['settle_ratio'])}")
    n = len(rep["probes"])
    print(f"within ±{100 * rep['tolerance']:.0f} % of the reference: follow-through "
          f"{rep['follow_through_within']}/{n}, settle time {rep['settle_within']}/{n}")
    if "spread_within" in rep:
        print(f"the second reference within ±{100 * rep['tolerance']:.0f} % of the first: follow-through "
              f"{rep['spread_within']['follow_through']}/{n}, settle time {rep['spread_within']['settle']}/{n}")


@command("pleat-sudden-stop", build_parser)
def main(args):
    if not args.settle_threshold > 0:
        raise UsageError("--settle-threshold must be a positive speed in m/s")
    if not args.tolerance >= 0:
        raise UsageError("--tolerance must be 0 or more")
    if args.hold < 2:
        raise UsageError("--hold must be at least 2 frames")
    if args.probe_clips and not args.probes:
        raise UsageError("--probe-clips goes with --probes")
    if args.probes:
        if args.motion is not None or args.move is not None:
            raise UsageError("--probes chooses its own clips and cuts; leave out --motion and --move")
        from pleat.eval.scene import EVAL_FPS
        if args.hold < PROBE_MIN_HOLD_S * EVAL_FPS - 1e-9:
            raise UsageError(f"--probes needs --hold of at least {PROBE_MIN_HOLD_S} s "
                             f"({int(np.ceil(PROBE_MIN_HOLD_S * EVAL_FPS))} frames)")
        probes = probe_set(args.probe_clips) if args.probe_clips else PROBES
        rep = run_probes(args.asset, args.hold, progress=not args.quiet, region=args.region,
                         threshold_m_s=args.settle_threshold, tolerance=args.tolerance, probes=probes,
                         spread=args.reference_spread)
    else:
        move = DEFAULT_MOVE if args.move is None else args.move
        if move < 1:
            raise UsageError("--move must be at least 1 frame")
        rep = run(args.asset, args.motion or DEFAULT_MOTION, move, args.hold, progress=not args.quiet,
                  region=args.region, threshold_m_s=args.settle_threshold, tolerance=args.tolerance,
                  spread=args.reference_spread)
    write_text(args.out, json.dumps(rep, indent=1))
    if args.plot:
        plot(rep, args.plot)
    if args.probes:
        _print_probes(rep)
        return 0
    for k in ("reference", "pleat", "lbs"):
        r = rep[k]
        print(f"{k}: {r['mean_speed_first_0.2s_after_stop']:.3f} m/s in the 0.2 s after the stop, below 0.01 m/s "
              f"after {r['settles_after_s']:.2f} s, final {r['final_speed_m_s']:.4f} m/s; above its floor "
              f"{r['floor_m_s']:.4f} m/s: follow-through {r['follow_through_mm']:.1f} mm, settles after "
              f"{r['settle_s']:.2f} s")
    c = rep["pleat_vs_reference"]
    print(f"pleat / reference: follow-through ×{_show(c['follow_through_ratio'])}, "
          f"settle time ×{_show(c['settle_ratio'])}")
    if "spread_vs_reference" in rep:
        s = rep["spread_vs_reference"]
        print(f"second reference / reference: follow-through ×{_show(s['follow_through_ratio'])}, "
              f"settle time ×{_show(s['settle_ratio'])}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
