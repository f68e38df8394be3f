"""pleat-garment: make a procedural garment (or diffuse skin and shape onto your own OBJ) → an npz."""
import argparse
import sys
from pathlib import Path

import numpy as np


def main(argv=None):
    from .generate import GARMENT_NAMES
    parser = argparse.ArgumentParser(prog="pleat-garment", description=__doc__.split(": ", 1)[1])
    parser.add_argument("name", nargs="?", help=f"one of {', '.join(GARMENT_NAMES)} (or the name for --from-obj)")
    parser.add_argument("--vertices", type=int, default=None, help="vertex count (1000-5000; ±5%%)")
    parser.add_argument("--from-obj", default=None, help="a rest-pose garment mesh fitted to the template body")
    parser.add_argument("--body", default=None, help="body npz (default assets/body.npz)")
    parser.add_argument("--out", default=None, help="output npz (default data/garments/NAME.npz)")
    args = parser.parse_args(argv)
    from ..sim.scene import load_body
    from .generate import garment_from_obj, make_garment
    from .mesh import check_manifold
    if args.from_obj is None and args.name is None:
        parser.error("give a garment name or --from-obj FILE")
    if args.vertices is not None and not 500 <= args.vertices <= 20000:
        parser.error("--vertices must be within 500..20000")
    body = load_body(args.body)
    if args.from_obj:
        garment = garment_from_obj(args.from_obj, body=body, name=args.name)
    else:
        if args.name not in GARMENT_NAMES:
            parser.error(f"unknown garment {args.name!r}; known: {', '.join(GARMENT_NAMES)}")
        garment = make_garment(args.name, vertices=args.vertices, body=body)
    out = Path(args.out) if args.out else Path(__file__).resolve().parents[3] / "data" / "garments" / f"{garment.name}.npz"
    out.parent.mkdir(parents=True, exist_ok=True)
    garment.save(out)
    el = garment.rest_edge_length
    problems = check_manifold(garment.faces.astype(np.int64), garment.num_vertices)
    print(f"pleat-garment: {garment.name}: {garment.num_vertices} vertices, {len(garment.faces)} faces, "
          f"edge {el.min() * 1000:.1f}-{el.max() * 1000:.1f} mm (cv {el.std() / el.mean():.3f}), "
          f"{len(garment.pinned)} pinned{', PROBLEMS: ' + '; '.join(problems) if problems else ''} → {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
