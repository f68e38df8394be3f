"""`pleat-garment import`: a garment mesh made in a DCC tool → a Pleat garment npz (docs/garments.md, "Your own
garment").

    pleat-garment import shirt.obj --units cm --up y --fit --out data/garments/shirt.npz --write-obj shirt_sim.obj

The mesh must be modelled on the Pleat body in its rest pose (the wide A-pose of docs/body.md: arms 25° below the
horizontal, forearms straight, β = 0; `pleat-garment scene --out kit/` writes that body for the DCC tool).
Steps, each reported:
1. read (OBJ, glTF 2.0 / GLB), convert units and up axis, weld duplicate vertices (glTF exporters split vertices
   at UV seams), drop unreferenced vertices, check it is an oriented manifold (the simulator's cloth model needs one);
2. orient: faces turned outward (away from the body) if most of them face it;
3. fit (optional, `--fit [MM]`): vertices closer than the margin to the body, or inside it, are pushed out along the
   body normal, and the push is spread to their neighbours so that no spike is left;
4. penetration: vertices inside the body and within the simulator's 4 mm collision thickness, before and after;
5. skin weights and shape blend shapes diffused from the body (`diffuse_from_body`, as `make_garment` does);
6. pins: `auto` (the waistband of a garment that ends at the waist, as the generator pins pants; none for tops),
   `waistband`, `collar`, `none`, a vertex-index file, or an OBJ group / glTF node (`--pin-group`).
Vertex order is kept except where welding or dropping unreferenced vertices changes it (reported): a point cache
from the DCC tool must follow the order of the mesh that was imported — simulate the `--write-obj` mesh.
"""
import argparse
import json
from pathlib import Path

import numpy as np

from pleat.cli import InputError, add_quiet
from . import mesh as M
from .meshio import UNITS_M, from_pleat_axes, read_mesh, to_pleat_axes, unit_scale, weld, write_obj

COLLISION_THICKNESS_M = 0.004      # the simulator's collision ε (docs/simulator.md)
DEFAULT_FIT_MM = 6.0
PIN_MODES = ("auto", "none", "waistband", "collar")


def _neighbour_average(faces, n):
    A = M.adjacency(faces, n)
    deg = np.asarray(A.sum(1)).ravel()
    return A.multiply(1.0 / np.maximum(deg, 1)[:, None]).tocsr()


def penetration(collider, x):
    """(vertices inside the body, vertices within the collision thickness incl. inside, deepest inside in m)."""
    d = collider.signed_distance(x, k=8)[0]
    return int((d < 0).sum()), int((d < COLLISION_THICKNESS_M).sum()), float(max(0.0, -d.min()))


def fit_to_body(x, faces, collider, margin_m, smooth_iterations=12, final_iterations=8):
    """Vertices closer than margin_m to the body (or inside it) move out along the body normal; the push is then
    spread to the neighbours (half of the neighbours' mean displacement, where that is larger than a vertex's own),
    so a dent becomes a smooth bulge. A last few pure pushes guarantee the margin where the sign test can."""
    x0 = np.asarray(x, np.float64)
    P = _neighbour_average(faces, len(x0))
    disp = np.zeros_like(x0)
    for _ in range(smooth_iterations):
        d, _, n = collider.signed_distance(x0 + disp, k=8)
        low = d < margin_m
        if not low.any():
            break
        disp[low] += (margin_m - d[low])[:, None] * n[low]
        spread = P @ disp
        grow = np.linalg.norm(0.5 * spread, axis=1) > np.linalg.norm(disp, axis=1)
        disp[grow] = 0.5 * spread[grow]
    return collider.push_out(x0 + disp, margin_m, final_iterations)


def _outward_fraction(x, faces, collider):
    """Fraction of the vertices near the body whose garment normal agrees with the body's normal there (outward
    faces; also right for vertices that are inside the body)."""
    n = M.vertex_normals(x, faces)
    dist, idx = collider.closest_vertex(x)
    near = dist < max(0.05, np.percentile(dist, 50))
    return float(np.mean(np.sum(n[near] * collider.normals[idx[near]], axis=1) > 0))


def read_pin_file(path, count):
    """Vertex indices (0-based, into the mesh file's vertices) from a JSON list, a JSON object {"pins": [...]} or
    {group name: [...]} (all groups), or a text file of integers separated by spaces, commas or lines (# comments)."""
    path = Path(path)
    if not path.is_file():
        raise InputError(path, "no such pin file")
    text = path.read_text(encoding="utf-8")
    try:
        data = json.loads(text)
    except json.JSONDecodeError:
        words = " ".join(line.split("#", 1)[0] for line in text.splitlines()).replace(",", " ").split()
        try:
            data = [int(w) for w in words]
        except ValueError:
            raise InputError(path, "pin file is neither JSON nor a list of integer vertex indices") from None
    if isinstance(data, dict):
        data = data["pins"] if "pins" in data else [i for v in data.values() for i in v]
    if not isinstance(data, list) or not all(isinstance(i, int) and not isinstance(i, bool) for i in data):
        raise InputError(path, "pins must be a list of integer vertex indices (0-based)")
    idx = np.asarray(data, np.int64)
    if len(idx) and (idx.min() < 0 or idx.max() >= count):
        bad = int(idx.min() if idx.min() < 0 else idx.max())
        raise InputError(path, f"pin index {bad} is outside the mesh's 0..{count - 1} (indices are 0-based)")
    return np.unique(idx)


def _loops_with_centroids(x, faces):
    """Boundary loops with their centroids (openings around the trunk have theirs near x = 0, limbs' far off)."""
    return [(L, x[L].mean(0)) for L in M.boundary_loops(faces)]


def pick_pins(mode, x, faces, body, name=""):
    """Pinned vertices by a heuristic: (indices, what was done in words)."""
    if mode == "none":
        return np.zeros(0, np.int64), "none"
    names = list(body.joint_names)
    J = body.joints()
    neck, waist = J[names.index("neck")], J[names.index("spine1")] - np.array([0.0, 0.03, 0.0])
    loops = [(L, c) for L, c in _loops_with_centroids(x, faces) if abs(c[0]) < 0.12]    # trunk openings, not limbs
    if not loops:
        if mode == "auto":
            return np.zeros(0, np.int64), "none (auto: no opening around the trunk)"
        raise InputError(None, f"--pins {mode}: the garment has no opening around the trunk")
    top = max(loops, key=lambda lc: lc[1][1])
    if mode == "auto":
        # a garment whose highest trunk opening is nearer the waist than the neck ends at the waist: pants, skirts
        if abs(top[1][1] - waist[1]) < abs(top[1][1] - neck[1]):
            return np.sort(top[0]), f"waistband ({len(top[0])} vertices; auto: the garment ends at the waist)"
        return np.zeros(0, np.int64), "none (auto: a top hangs on the shoulders, as the generator's tops)"
    target = waist if mode == "waistband" else neck
    L, c = min(loops, key=lambda lc: np.linalg.norm(lc[1] - target))
    return np.sort(L), f"{mode} ({len(L)} vertices, the opening {np.linalg.norm(c - target) * 100:.0f} cm from the " \
                       f"{'waist' if mode == 'waistband' else 'neck joint'})"


def import_garment(path, body, units="m", up="y", fit_mm=None, pins="auto", pin_group=None, name=None,
                   weld_mm=None):
    """Reads, checks, fits and dresses a DCC garment mesh. Returns (Garment, report dict, vertex map [file
    vertices] → garment vertex or −1, conversion dict)."""
    from pleat.body.model import BodyCollider
    from .garment import Garment
    from .generate import diffuse_from_body
    path = Path(path)
    mesh = read_mesh(path)
    report = {"file": str(path), "format": mesh.source, "file_vertices": len(mesh.vertices),
              "file_triangles": len(mesh.faces), "notes": list(mesh.notes)}
    try:
        x = to_pleat_axes(mesh.vertices, up, units)
    except ValueError as exc:
        raise InputError(path, str(exc)) from None
    # weld: glTF splits vertices at UV seams; OBJ only when asked
    tol = (weld_mm if weld_mm is not None else (0.0 if mesh.source != "OBJ" else None))
    vmap = np.arange(len(x))
    faces = mesh.faces
    if tol is not None:
        x, faces, vmap = weld(x, faces, tol * 1e-3)
        report["welded"] = int(len(mesh.vertices) - len(x))
    used = np.unique(faces)
    if len(used) != len(x):
        report["dropped_unreferenced"] = int(len(x) - len(used))
        remap = np.full(len(x), -1, np.int64)
        remap[used] = np.arange(len(used))
        x, faces = x[used], remap[faces]
        vmap = np.where(vmap >= 0, remap[np.maximum(vmap, 0)], -1)
    report["order_kept"] = bool(np.array_equal(vmap, np.arange(len(mesh.vertices))))
    height = float(np.ptp(x[:, 1]))
    extent = float(np.ptp(x, axis=0).max())
    if not 0.05 <= extent <= 4.0:
        raw = extent / unit_scale(units)
        fits = [u for u in UNITS_M if 0.3 <= raw * UNITS_M[u] <= 2.5]
        hint = f"; as {fits[0]!r} it would be {raw * UNITS_M[fits[0]]:.2f} m" if fits else ""
        raise InputError(path, f"is {extent:.3g} m across with --units {units}: not a garment on a 1.8 m body "
                               f"(wrong --units?{hint})")
    problems = M.check_manifold(faces, len(x))
    if problems:
        raise InputError(path, f"is not an oriented manifold triangle mesh: {'; '.join(problems)} (the cloth "
                               "simulator and the blend shapes need one: merge by distance, recalculate normals, "
                               "split non-manifold edges in the DCC tool)")
    collider = BodyCollider(body.v_template, body.faces)
    d0 = collider.signed_distance(x, k=8)[0]
    report["distance_to_body_mm"] = {"median": 1e3 * float(np.median(d0)), "p95": 1e3 * float(np.percentile(d0, 95))}
    if np.median(np.abs(d0)) > 0.15:
        raise InputError(path, f"lies {np.median(np.abs(d0)) * 100:.0f} cm from the body (median): it must be "
                               "modelled on the Pleat body in its rest pose (A-pose, docs/body.md), in metres +Y up "
                               "after --units/--up")
    frac = _outward_fraction(x, faces, collider)
    report["flipped"] = frac < 0.5
    if report["flipped"]:
        faces = faces[:, [0, 2, 1]]
    report["outward_fraction"] = max(frac, 1.0 - frac)
    inside0, close0, deep0 = penetration(collider, x)
    report["penetration_before"] = {"inside": inside0, "within_4mm": close0, "deepest_mm": 1e3 * deep0}
    moved = np.zeros(len(x))
    if fit_mm is not None:
        x_fit = fit_to_body(x, faces, collider, fit_mm * 1e-3)
        moved = np.linalg.norm(x_fit - x, axis=1)
        x = x_fit
        hit = moved > 1e-6
        report["fit"] = {"margin_mm": float(fit_mm), "moved_vertices": int(hit.sum()),
                         "max_move_mm": 1e3 * float(moved.max()),
                         "mean_move_mm": 1e3 * float(moved[hit].mean()) if hit.any() else 0.0}
    inside1, close1, deep1 = penetration(collider, x)
    report["penetration_after"] = {"inside": inside1, "within_4mm": close1, "deepest_mm": 1e3 * deep1}
    skin_indices, skin_weights, shape_blend = diffuse_from_body(x, faces, body)
    # pins
    if pin_group is not None:
        if pin_group not in mesh.groups:
            raise InputError(path, f"has no group {pin_group!r} (groups: {', '.join(mesh.groups) or 'none'})")
        pinned = np.unique(vmap[mesh.faces[mesh.groups[pin_group]]])
        pinned = pinned[pinned >= 0]
        how = f"group {pin_group!r} ({len(pinned)} vertices)"
    elif pins not in PIN_MODES:
        file_pins = read_pin_file(pins, len(mesh.vertices))
        pinned = np.unique(vmap[file_pins])
        pinned = pinned[pinned >= 0]
        how = f"file {pins} ({len(pinned)} vertices)"
    else:
        pinned, how = pick_pins(pins, x, faces, body)
    report["pins"] = how
    gname = name or path.stem
    garment = Garment.build(name=gname, template=x, faces=faces, skin_indices=skin_indices, skin_weights=skin_weights,
                            shape_blend=shape_blend, pinned=np.asarray(pinned, np.int32))
    dominant = np.bincount(garment.skin_indices[:, 0], minlength=len(body.joint_names))
    order = np.argsort(-dominant)
    report["skin_joints"] = {body.joint_names[j]: int(dominant[j]) for j in order if dominant[j] > 0}
    report["influencing_joints"] = int(len(np.unique(garment.skin_indices[garment.skin_weights > 1e-3])))
    el = garment.rest_edge_length
    report.update(name=gname, vertices=garment.num_vertices, faces=len(garment.faces), pinned=len(garment.pinned),
                  height_m=height, edge_mm=[1e3 * float(el.min()), 1e3 * float(el.max())],
                  openings=len(M.boundary_loops(garment.faces)),
                  components=int(len(np.unique(M.face_components(garment.faces, garment.num_vertices)))))
    return garment, report, vmap, {"units": units, "up": up}


def report_lines(r):
    """The import report, one fact per line."""
    pb, pa = r["penetration_before"], r["penetration_after"]
    out = [f"read {r['file']} ({r['format']}): {r['file_vertices']} vertices, {r['file_triangles']} triangles"]
    out += [f"  note: {n}" for n in r["notes"]]
    if r.get("welded"):
        out.append(f"welded {r['welded']} duplicate vertices (UV seams)")
    if r.get("dropped_unreferenced"):
        out.append(f"dropped {r['dropped_unreferenced']} vertices no triangle uses")
    if not r["order_kept"]:
        out.append("vertex order differs from the file: simulate the --write-obj mesh, not the original")
    out.append(f"garment {r['name']}: {r['vertices']} vertices, {r['faces']} faces, {r['openings']} openings, "
               f"{r['components']} piece{'s' if r['components'] != 1 else ''}, edges "
               f"{r['edge_mm'][0]:.1f}-{r['edge_mm'][1]:.1f} mm, {r['height_m'] * 100:.0f} cm tall")
    out.append(f"distance to the body: median {r['distance_to_body_mm']['median']:.1f} mm, p95 "
               f"{r['distance_to_body_mm']['p95']:.1f} mm")
    out.append("faces turned outward (most faced the body)" if r["flipped"] else
               f"faces point outward ({100 * r['outward_fraction']:.0f} % of the vertices near the body)")
    out.append(f"penetration before fit: {pb['inside']} vertices inside the body (deepest {pb['deepest_mm']:.1f} mm), "
               f"{pb['within_4mm']} within 4 mm")
    if "fit" in r:
        f = r["fit"]
        out.append(f"fit (margin {f['margin_mm']:g} mm): moved {f['moved_vertices']} vertices, max "
                   f"{f['max_move_mm']:.1f} mm, mean {f['mean_move_mm']:.1f} mm")
    out.append(f"penetration after fit: {pa['inside']} vertices inside the body (deepest {pa['deepest_mm']:.1f} mm), "
               f"{pa['within_4mm']} within 4 mm" if "fit" in r else
               "no fit asked (--fit [MM] pushes vertices out of the body)")
    total = sum(r["skin_joints"].values())
    shown = ", ".join(f"{k} {100 * v / total:.0f} %" for k, v in list(r["skin_joints"].items())[:8])
    out.append(f"skin weights: {r['influencing_joints']} joints influence the garment; strongest joint per vertex: "
               f"{shown}")
    out.append(f"pins: {r['pins']}")
    return out


def build_import_parser():
    p = argparse.ArgumentParser(
        prog="pleat-garment import",
        description="a garment mesh made in a DCC tool on the rest-pose body (OBJ, glTF 2.0, GLB) → a garment npz: "
                    "units and axes, fit out of the body, diffused skin weights, pins, a report (docs/garments.md)")
    p.add_argument("mesh", help="the mesh: .obj, .gltf or .glb, modelled on the body's rest pose (docs/body.md)")
    p.add_argument("--out", default=None, help="output file: the garment npz (default data/garments/NAME.npz)")
    p.add_argument("--name", default=None, help="garment name (default: the file name)")
    p.add_argument("--units", default=None,
                   help=f"length unit of the file: {', '.join(UNITS_M)} or metres per unit (default m; glTF is m)")
    p.add_argument("--up", default="y", choices=["y", "z"],
                   help="the file's up axis: y (Maya, Houdini, glTF, Blender's OBJ export) or z (Blender scene "
                        "axes, 3ds Max; the character facing -Y)")
    p.add_argument("--fit", nargs="?", type=float, const=DEFAULT_FIT_MM, default=None, metavar="MM",
                   help=f"push vertices out of the body to at least MM millimetres (default {DEFAULT_FIT_MM:g})")
    p.add_argument("--pins", default="auto",
                   help="auto (waistband of a garment that ends at the waist, none for tops), none, waistband, "
                        "collar, or a file of 0-based vertex indices (JSON list or text)")
    p.add_argument("--pin-group", default=None, help="pin the vertices of this OBJ group / glTF node instead")
    p.add_argument("--weld", type=float, default=None, metavar="MM",
                   help="merge vertices closer than MM (default: exact duplicates for glTF, none for OBJ)")
    p.add_argument("--body", default=None, help="body npz (default assets/body.npz)")
    p.add_argument("--write-obj", default=None,
                   help="also write the imported (fitted) mesh as OBJ in the file's units and axes: the mesh to "
                        "simulate in the DCC tool (its vertex order is the garment's)")
    p.add_argument("--json", default=None, help="also write the report as JSON to this file")
    add_quiet(p)
    return p


def import_main(argv):
    from pleat.fileio import write_text
    from pleat.paths import GARMENTS_DIR
    from pleat.sim.scene import load_body
    args = build_import_parser().parse_args(argv)
    body = load_body(args.body)
    units = args.units or "m"
    garment, report, _, _ = import_garment(args.mesh, body, units, args.up, args.fit, args.pins, args.pin_group,
                                           args.name, args.weld)
    out = Path(args.out) if args.out else GARMENTS_DIR / f"{garment.name}.npz"
    out.parent.mkdir(parents=True, exist_ok=True)
    out = garment.save(out)
    lines = report_lines(report)
    if args.write_obj:
        write_obj(args.write_obj, from_pleat_axes(garment.template, args.up, units), garment.faces,
                  header=f"pleat-garment import of {Path(args.mesh).name}: {garment.num_vertices} vertices in the "
                         f"garment's order, units {units}, up {args.up}")
        lines.append(f"wrote the mesh to simulate: {args.write_obj}")
        report["write_obj"] = str(args.write_obj)
    if args.json:
        write_text(args.json, json.dumps(report, indent=1))
    for line in lines:
        print(f"pleat-garment import: {line}")
    print(f"pleat-garment import: wrote {out}")
    return 0
