"""pleat-eval: accuracy of a Pleat asset against the reference simulator on one clip (docs/accuracy.md).

    pleat-eval --asset A.pleat --motion CLIP --json OUT.json [--plots DIR] [--beta b0,b1,..] [--material m,mu,lam,k]
               [--max-frames 300] [--teacher RUN_DIR_OR_stage1.pt] [--reference-spread] [--reference blender]

Runs, on the same body, β, material and motion (resampled to 30 fps, cut at --max-frames):
  pleat    the asset through the C runtime (pleat.runtime → libpleat.so); `step_us` is the median plInstance_Step time
  lbs      the same garment with the zero network (LBS of the β-shaped template), through the C runtime the same way
  teacher  the stage-1 network Φ rolled out in torch, if --teacher is given and torch imports (else null + reason)
  reference  pleat.sim's implicit-Euler solve, cached in out/cache/sim/ (the slow part); with --reference blender,
           Blender's cloth on the same scene instead (pleat_blender.teacher, needs bpy)
  reference_spread  with --reference-spread: a second reference from a start state moved by 1 µm, scored against the
           first. Cloth buckles, so two equally valid references drift apart; no method's error below this means
           anything (docs/accuracy.md, "How exact the reference is")
and scores each with pleat.eval.metrics: mean / p95 vertex error (mm), edge-strain error, jitter (m/s²), penetration
(share of vertices inside the posed body, %, and the deepest, mm); and the same per garment region (pleat.eval.regions:
the dress's skirt, the pants' crotch, ...) under each method's `regions`.
"""
import json
import sys
import time
from pathlib import Path

import numpy as np

from pleat.cli import UsageError, add_quiet, command, doc_parser, positive_float
from pleat.eval import metrics
from pleat.eval import scene as S
from pleat.fileio import finish_figure, write_text

METHODS = ("pleat", "lbs", "teacher")
SPREAD_PERTURBATION_M = 1e-6     # --reference-spread: the second reference's start state, moved by 1 µm per vertex


def parse_floats(text, count=None, what="value"):
    if text is None:
        return None
    parts = [float(p) for p in str(text).replace(" ", ",").split(",") if p != ""]
    if count is not None and len(parts) != count:
        raise ValueError(f"{what} needs {count} comma-separated numbers, got {text!r}")
    return np.array(parts, np.float64)


def _clamped_material(weights, material):
    lo, hi = np.asarray(weights["material_min"], np.float64), np.asarray(weights["material_max"], np.float64)
    if material is None:
        return np.asarray(weights["material_default"], np.float64)
    return np.clip(material, lo, hi)


def _clamped_beta(weights, beta):
    B = len(weights["shape_blend"])
    b = np.zeros(B)
    if beta is not None:
        b[:len(beta)] = beta[:B]
    lo, hi = weights.get("beta_range", (-4.0, 4.0))
    return np.clip(b, float(lo), float(hi))


def teacher_rollout(checkpoint, clip, beta, material, weights):
    """Φ's garment along the clip [T, N, 3], or raises with the reason it cannot be produced."""
    from types import SimpleNamespace

    import torch
    from pleat.train import core
    path = Path(checkpoint)
    run_dir = path.parent if path.is_file() else path
    model, setup, cfg, _ = core.load_stage1(run_dir)
    if setup.N != len(weights["template"]):
        raise ValueError(f"teacher garment has {setup.N} vertices, the asset {len(weights['template'])}")
    c = SimpleNamespace(rotations=S.clip_rotations_for(clip, setup.joint_names), fps=clip.fps,
                        root_translation=clip.root_translation, root_rotation=clip.root_rotation)
    T = clip.num_frames
    win = setup.pose_window(c, 0, T, beta, prepend_first=2)        # frames 0, 1 copy the first pose
    lo, hi = setup.material_min, setup.material_max
    window = core.Window(setup, win, beta, material, (material - lo) / (hi - lo))
    out = [window.states[2].detach().cpu().numpy()]
    with torch.no_grad():
        for f in range(3, len(win["dt"])):
            node, edges, body, recv = window.features(f)
            _, disp = model(node, edges, body, recv, setup.levels)
            out.append(window.advance(f, disp).detach().cpu().numpy())
    return np.asarray(out, np.float32)


def evaluate(asset_path, motion, beta=None, material=None, max_frames=300, teacher=None, body_path=None,
             cache_dir=None, progress=True, context=None, reference_spread=False, fps=None, network_rate_hz=0.0,
             body_contact_offset_m=None, reference="pleat"):
    """The report dict of one asset on one clip (what --json writes), plus per-frame arrays under 'per_frame'.
    reference_spread: also simulate the reference from a start moved by SPREAD_PERTURBATION_M and score it against
    the first like a method (`reference_spread`): the floor under which no method's error means anything.
    fps: the frame rate of the clip, the reference and the runtime's steps (default 30); network_rate_hz: the
    runtime's plInstanceDef.network_rate_hz for `pleat` (0: the networks run every step); body_contact_offset_m:
    its plInstanceDef.body_contact_offset_m (None: the SDK's default clearance); reference: the teacher simulator
    ("pleat" or "blender", pleat.eval.reference.TEACHERS) of the reference and its spread. Every method also gets
    `surface_inside` (pleat.sim.surface: points sampled over its faces inside the body, on 10 frames)."""
    from pleat import runtime
    from pleat.body import BodyModel
    from pleat.eval.reference import cached_simulate, check_teacher
    from pleat.eval.regions import garment_regions

    from pleat.asset import AssetError
    from pleat.cli import InputError
    try:
        data, weights = S.read_weights(asset_path)
    except AssetError as exc:
        raise InputError(asset_path, f"not a valid Pleat asset ({exc.code}: {exc})") from None
    try:
        check_teacher(reference)
    except ValueError as exc:
        raise InputError(None, f"--reference: {exc}") from None
    body = BodyModel.load(body_path)
    clip = S.load_motion(motion, body, fps or S.EVAL_FPS, max_frames)     # bad clips fail here, before any work
    mismatch = S.skeleton_mismatch_mm(weights, body)
    if not mismatch < 1.0:
        raise InputError(asset_path, f"the asset's skeleton differs from the body's by {mismatch:.1f} mm; "
                                     "evaluate it against the body it was built on (--body)")
    T, dt = clip.num_frames, 1.0 / clip.fps
    beta = _clamped_beta(weights, beta)
    material = _clamped_material(weights, material)
    garment = S.garment_from_asset(weights)
    collide = garment.body_collision_mask(body)
    regions = garment_regions(str(weights.get("garment_name")), weights["template"], weights["faces"], body,
                              weights["skin_indices"], weights["skin_weights"])

    own_context = context is None
    ctx = context or runtime.Context()
    try:
        runs = {"pleat": S.clip_rollout(ctx, data, weights, clip, beta, material, network_rate_hz=network_rate_hz,
                                        body_contact_offset_m=body_contact_offset_m),
                "lbs": S.clip_rollout(ctx, S.lbs_only_bytes(weights), weights, clip, beta, material)}
    finally:
        if own_context:
            ctx.close()
    t0 = time.perf_counter()
    ref, ref_info = cached_simulate(garment, body, clip, beta, material, T, cache_dir=cache_dir, progress=progress,
                                    teacher=reference)
    ref_info["wall_s"] = time.perf_counter() - t0

    preds = {k: r.positions for k, r in runs.items()}
    teacher_reason = None
    if teacher is None:
        teacher_reason = "no --teacher checkpoint given"
    else:
        try:
            preds["teacher"] = teacher_rollout(teacher, clip, beta, material, weights)
        except Exception as exc:   # noqa: BLE001 - the report says why the teacher is missing
            teacher_reason = f"{type(exc).__name__}: {exc}"

    body_v, _ = S.posed_body(body, clip, beta)
    report = dict(asset=str(asset_path), garment=str(weights.get("garment_name")),
                  model="lbs-only" if S.is_lbs_only(weights) else "network",
                  clip=clip.name, frames=int(T), fps=float(clip.fps), beta=beta.tolist(), material=material.tolist(),
                  vertices=int(len(weights["template"])), skeleton_mismatch_mm=mismatch,
                  network_rate_hz=float(network_rate_hz), body_contact_offset_m=body_contact_offset_m,
                  region_vertices={k: int(m.sum()) for k, m in regions.items()},
                  reference=dict(ref_info,
                                 penetration=_penetration_summary(body_v, body.faces, ref, collide)))
    per_frame = {}
    surface_frames = np.unique(np.linspace(0, T - 1, min(10, T)).round().astype(int))

    def surface(positions):
        from pleat.sim.surface import surface_inside
        return surface_inside(body_v[surface_frames], body.faces, np.asarray(positions)[surface_frames],
                              weights["faces"], collide)
    report["reference"]["surface_inside"] = surface(ref)

    def score(name, positions):
        sd = S.signed_distances(body_v, body.faces, positions, collide)
        rest = garment.shaped(beta)
        s = metrics.score(positions, ref, weights["faces"], rest, dt, sd)
        s["regions"] = metrics.score_regions(positions, ref, weights["faces"], rest, regions, sd)
        s["surface_inside"] = surface(positions)
        per_frame[name] = dict(error_mm=s.pop("per_frame_mean_mm"), penetration_pct=s.pop("per_frame_pct"))
        return s

    for k in METHODS:
        report[k] = score(k, preds[k]) if k in preds else None
    report["teacher_reason"] = teacher_reason
    report["reference_spread"] = None
    if reference_spread:
        twin, twin_info = cached_simulate(garment, body, clip, beta, material, T, cache_dir=cache_dir,
                                          progress=progress, start_perturbation_m=SPREAD_PERTURBATION_M,
                                          teacher=reference)
        report["reference_spread"] = dict(score("reference_spread", twin), start_perturbation_m=SPREAD_PERTURBATION_M,
                                          key=twin_info["key"], cache_hit=twin_info["cache_hit"])
        # Where the spread is as large as the errors, one reference is a noisy target: score every method against
        # the mean of the two as well (a method that predicts the average fold gets its due there)
        mean_ref = 0.5 * (np.asarray(ref, np.float64) + np.asarray(twin, np.float64))
        report["against_reference_mean"] = {
            k: float(metrics.vertex_error_mm(preds[k], mean_ref).mean()) for k in METHODS if k in preds}
    for k, r in runs.items():
        report[k]["step_us"] = float(np.median(r.step_us))
        report[k]["mean_step_us"] = float(np.mean(r.step_us))     # with a network rate the steps differ in cost
        report[k]["numeric_resets"] = r.resets
        report[k]["finite"] = bool(np.isfinite(r.positions).all())
    report["per_frame"] = per_frame
    return report


def _penetration_summary(body_v, faces, positions, collide=None):
    p = metrics.penetration(S.signed_distances(body_v, faces, positions, collide))
    return dict(penetration_pct=p["penetration_pct"], max_depth_mm=p["max_depth_mm"])


def write_plots(report, out_dir):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    stem = Path(report["asset"]).stem + "_" + Path(report["clip"]).name.replace("/", "_")
    fig, axes = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
    t = np.arange(report["frames"]) / report["fps"]
    for k, series in report["per_frame"].items():
        axes[0].plot(t, series["error_mm"], label=k)
        axes[1].plot(t, series["penetration_pct"], label=k)
    axes[0].set_ylabel("mean vertex error (mm)")
    axes[1].set_ylabel("vertices inside body (%)")
    axes[1].set_xlabel("time (s)")
    axes[0].legend()
    axes[0].set_title(f"{report['garment']} ({report['model']}) on {report['clip']}")
    return finish_figure(fig, out_dir / f"{stem}.png", dpi=80)


def build_parser():
    ap = doc_parser("pleat-eval", __doc__)
    ap.add_argument("--asset", required=True, help="the .pleat asset to score")
    ap.add_argument("--motion", required=True, help="clip file or name (DeepMimic .txt, .bvh, .amc, AMASS .npz, "
                                                    "Pleat clip .npz)")
    ap.add_argument("--beta", default=None, help="comma-separated β (missing components are 0; default all 0)")
    ap.add_argument("--material", default=None, help="m,mu,lambda,k (default: the asset's default material)")
    ap.add_argument("--out", "--json", dest="json", required=True,
                    help="output file: the JSON report (--json is the older name)")
    ap.add_argument("--plots", default=None, help="folder for the per-frame error / penetration plot")
    ap.add_argument("--max-frames", type=int, default=300, help="frames of the clip scored (at least 2)")
    ap.add_argument("--teacher", default=None, help="stage-1 checkpoint (stage1.pt or its run folder)")
    ap.add_argument("--body", default=None, help="body npz (default assets/body.npz)")
    ap.add_argument("--cache-dir", default=None, help="reference cache (default out/cache/sim)")
    ap.add_argument("--per-frame", action="store_true", help="keep the per-frame series in the JSON")
    ap.add_argument("--reference-spread", action="store_true",
                    help="also score a second reference started 1 µm apart against the first (doubles the "
                         "reference's cost once; cached)")
    ap.add_argument("--reference", default="pleat", choices=["pleat", "blender"],
                    help="the reference simulator: Pleat's (default) or Blender's cloth (needs bpy; docs/accuracy.md, "
                         "\"A second teacher\")")
    ap.add_argument("--fps", type=positive_float, default=None,
                    help="frame rate of the clip, reference and steps (default 30)")
    ap.add_argument("--body-contact-offset", type=float, default=None, metavar="M",
                    help="pleat's body-contact clearance in metres (plInstanceDef.body_contact_offset_m; default the "
                         "SDK's, 0.001)")
    ap.add_argument("--network-rate", type=float, default=0.0,
                    help="pleat's network update rate in Hz (plInstanceDef.network_rate_hz; default 0: every step)")
    return add_quiet(ap)


@command("pleat-eval", build_parser)
def main(args):
    try:
        beta = parse_floats(args.beta, what="--beta")
        material = parse_floats(args.material, 4, "--material")
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    if args.max_frames < 2:
        raise UsageError("--max-frames must be at least 2")
    if not args.network_rate >= 0:
        raise UsageError("--network-rate must be 0 (every step) or a positive rate in Hz")
    report = evaluate(args.asset, args.motion, beta, material, args.max_frames, args.teacher, args.body,
                      args.cache_dir, not args.quiet, reference_spread=args.reference_spread, fps=args.fps,
                      network_rate_hz=args.network_rate, body_contact_offset_m=args.body_contact_offset,
                      reference=args.reference)
    if args.plots:
        report["plot"] = str(write_plots(report, args.plots))
    if not args.per_frame:
        report.pop("per_frame")
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    write_text(args.json, json.dumps(report, indent=1))
    summary = {k: (None if report[k] is None else {m: round(report[k][m], 3) for m in
                                                   ("mean_mm", "p95_mm", "penetration_pct", "max_depth_mm")})
               for k in METHODS + ("reference_spread",)}
    print(json.dumps(dict(frames=report["frames"], step_us=round(report["pleat"]["step_us"], 1), **summary)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
