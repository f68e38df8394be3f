"""pleat-garment: make a procedural garment (or diffuse skin and shape onto your own OBJ) → an npz; `pleat-garment
list` shows the garments there are; `pleat-garment import MESH` brings a DCC mesh (OBJ, glTF) with a fit, pins and
a report; `pleat-garment scene --out DIR` writes the body (and garment, motion) for a DCC tool."""
import argparse
import sys
from pathlib import Path

import numpy as np

from pleat.cli import InputError, add_quiet, command
from pleat.paths import ASSETS_DIR, GARMENTS_DIR


def build_parser():
    from .generate import GARMENT_NAMES
    parser = argparse.ArgumentParser(prog="pleat-garment", description=__doc__.split(": ", 1)[1])
    parser.add_argument("name", nargs="?",
                        help=f"one of {', '.join(GARMENT_NAMES)} (or the name for --from-obj); `list`: print the "
                             "procedural garments, the garment npz files in data/garments and the shipped assets; "
                             "`import MESH ...`: see pleat-garment import --help; `scene ...`: see pleat-garment scene "
                             "--help")
    parser.add_argument("--vertices", type=int, default=None, help="vertex count (500-20000; ±5%%)")
    parser.add_argument("--from-obj", default=None, help="a rest-pose garment mesh fitted to the template body")
    parser.add_argument("--body", default=None, help="body npz (default assets/body.npz)")
    parser.add_argument("--out", default=None, help="output file: the garment npz (default data/garments/NAME.npz)")
    add_quiet(parser)
    return parser


def list_garments():
    """Rows (kind, name, where, detail) of what `pleat-garment list` prints."""
    from .generate import DEFAULT_VERTICES, GARMENT_NAMES
    rows = [("procedural", n, "pleat-garment " + n, f"{DEFAULT_VERTICES[n]} vertices by default")
            for n in GARMENT_NAMES]
    for p in sorted(GARMENTS_DIR.glob("*.npz")) if GARMENTS_DIR.is_dir() else []:
        try:
            with np.load(p, allow_pickle=False) as z:
                detail = f"{len(z['template'])} vertices, {len(z['faces'])} faces"
        except (OSError, ValueError, KeyError):
            detail = "unreadable"
        rows.append(("npz", p.stem, str(p), detail))
    for p in sorted(ASSETS_DIR.glob("*.pleat")) if ASSETS_DIR.is_dir() else []:
        rows.append(("asset", p.stem, str(p), f"{p.stat().st_size / 1024:.0f} KiB"))
    return rows


@command("pleat-garment")
def main(argv=None):
    from .generate import GARMENT_NAMES
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv and argv[0] == "import":
        from .importer import import_main
        return import_main(argv[1:])
    if argv and argv[0] == "scene":
        from .scene import scene_main
        return scene_main(argv[1:])
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.name == "list" and not args.from_obj:
        for kind, name, where, detail in list_garments():
            print(f"{kind:10s} {name:16s} {detail:32s} {where}")
        return 0
    from ..sim.scene import load_body
    from .generate import garment_from_obj, make_garment
    from .mesh import check_manifold
    if args.from_obj is None and args.name is None:
        parser.error("give a garment name, `list`, or --from-obj FILE")
    if args.vertices is not None and not 500 <= args.vertices <= 20000:
        parser.error("--vertices must be within 500..20000")
    if args.from_obj is None and args.name not in GARMENT_NAMES:
        parser.error(f"unknown garment {args.name!r}; known: {', '.join(GARMENT_NAMES)}")
    if args.from_obj and not Path(args.from_obj).is_file():
        raise InputError(args.from_obj, "no such OBJ file")
    body = load_body(args.body)
    if args.from_obj:
        try:
            garment = garment_from_obj(args.from_obj, body=body, name=args.name)
        except (ValueError, IndexError, KeyError) as exc:
            raise InputError(args.from_obj, f"cannot be made into a garment ({type(exc).__name__}: {exc})") from None
    else:
        garment = make_garment(args.name, vertices=args.vertices, body=body)
    out = Path(args.out) if args.out else GARMENTS_DIR / f"{garment.name}.npz"
    out.parent.mkdir(parents=True, exist_ok=True)
    out = garment.save(out)
    el = garment.rest_edge_length
    problems = check_manifold(garment.faces.astype(np.int64), garment.num_vertices)
    print(f"pleat-garment: {garment.name}: {garment.num_vertices} vertices, {len(garment.faces)} faces, "
          f"edge {el.min() * 1000:.1f}-{el.max() * 1000:.1f} mm (cv {el.std() / el.mean():.3f}), "
          f"{len(garment.pinned)} pinned{', PROBLEMS: ' + '; '.join(problems) if problems else ''} → {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
