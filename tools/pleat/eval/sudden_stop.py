"""A sudden stop: does the garment keep moving and settle, as the simulated one does? (docs/stability.md)

    PLEAT_LIBRARY=build/eval/libpleat.so pleat-sudden-stop --asset A.pleat \
        [--motion deepmimic_github/humanoid3d_jog] [--move 20] [--hold 40] --out out/stop.json [--plot stop.png]

The body plays the first `--move` frames of a clip, then holds its last pose (root included) for `--hold` frames.
Pleat (the C runtime), LBS-only and the reference simulator are run on it; per frame the garment's mean vertex speed
relative to the body (m/s; the body is still after the stop, so this is the cloth's own motion). A method that keeps
the dynamics shows what the reference shows: speed carried past the stop, decaying over a few tenths of a second;
LBS-only stops dead.
"""
import json
import sys
from dataclasses import replace

import numpy as np

from pleat.cli import add_quiet, command, doc_parser
from pleat.fileio import finish_figure, write_text


def stop_clip(clip, move, hold):
    idx = np.concatenate([np.arange(move), np.full(hold, move - 1)])
    return replace(clip, name=f"{clip.name}_stop", local_rotations=clip.local_rotations[idx],
                   root_translation=clip.root_translation[idx], root_rotation=clip.root_rotation[idx])


def speeds(positions, fps):
    """Mean vertex speed per frame [T − 1] (m/s)."""
    p = np.asarray(positions, np.float64)
    return np.linalg.norm(np.diff(p, axis=0), axis=-1).mean(axis=1) * fps


def settle(speed, move, fps, threshold_m_s=0.01):
    """(mean speed over the first 0.2 s after the stop, seconds until the speed stays below threshold)."""
    after = speed[move - 1:]
    n = max(1, int(round(0.2 * fps)))
    above = np.nonzero(after > threshold_m_s)[0]
    return float(after[:n].mean()), float((above[-1] + 1) / fps) if len(above) else 0.0


def run(asset, motion, move, hold, progress=False):
    from pleat import runtime
    from pleat.body import BodyModel
    from pleat.eval import scene as S
    from pleat.eval.reference import cached_simulate
    data, w = S.read_weights(asset)
    body = BodyModel.load(None)
    clip = stop_clip(S.load_motion(motion, body, S.EVAL_FPS, None), move, hold)
    beta = np.zeros(len(w["shape_blend"]))
    mat = np.asarray(w["material_default"], np.float64)
    with runtime.Context() as ctx:
        pleat = S.clip_rollout(ctx, data, w, clip, beta, mat).positions
        lbs = S.clip_rollout(ctx, S.lbs_only_bytes(w), w, clip, beta, mat).positions
    ref, _ = cached_simulate(S.garment_from_asset(w), body, clip, beta, mat, clip.num_frames, progress=progress)
    out = {"asset": str(asset), "motion": motion, "move_frames": move, "hold_frames": hold, "fps": clip.fps}
    for name, p in (("pleat", pleat), ("lbs", lbs), ("reference", ref)):
        v = speeds(p, clip.fps)
        first, t_settle = settle(v, move, clip.fps)
        out[name] = {"speed_m_s": v.tolist(), "mean_speed_first_0.2s_after_stop": first,
                     "settles_after_s": t_settle, "final_speed_m_s": float(v[-5:].mean())}
    return out


def plot(report, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 3.4))
    fps = report["fps"]
    start = max(0, report["move_frames"] - 6)        # the end of the motion and what follows, on a log scale
    for name in ("reference", "pleat", "lbs"):
        v = np.maximum(np.asarray(report[name]["speed_m_s"]), 1e-5)
        ax.plot(np.arange(start + 1, len(v) + 1) / fps, v[start:], label=name, marker=".")
    ax.axvline((report["move_frames"] - 1) / fps, color="k", ls=":", lw=1)
    ax.set_yscale("log")
    ax.set_xlabel("time (s); dotted: the body stops")
    ax.set_ylabel("mean garment vertex speed (m/s, log)")
    ax.set_title(f"sudden stop: {report['motion'].split('/')[-1]}")
    ax.legend(fontsize=8)
    finish_figure(fig, path, dpi=90)


def build_parser():
    ap = doc_parser("pleat-sudden-stop", __doc__)
    ap.add_argument("--asset", required=True, help="the .pleat asset")
    ap.add_argument("--motion", default="deepmimic_github/humanoid3d_jog", help="clip name or file")
    ap.add_argument("--move", type=int, default=20, help="frames of motion before the stop")
    ap.add_argument("--hold", type=int, default=40, help="frames held after it")
    ap.add_argument("--out", required=True, help="output file: the JSON report")
    ap.add_argument("--plot", default=None, help="output file: the speed plot (PNG)")
    return add_quiet(ap)


@command("pleat-sudden-stop", build_parser)
def main(args):
    rep = run(args.asset, args.motion, args.move, args.hold, progress=not args.quiet)
    write_text(args.out, json.dumps(rep, indent=1))
    if args.plot:
        plot(rep, args.plot)
    for k in ("reference", "pleat", "lbs"):
        r = rep[k]
        print(f"{k}: {r['mean_speed_first_0.2s_after_stop']:.3f} m/s in the 0.2 s after the stop, below 0.01 m/s "
              f"after {r['settles_after_s']:.2f} s, final {r['final_speed_m_s']:.4f} m/s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
