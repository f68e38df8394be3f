"""Cross-check of the reference simulator against an independent open simulator: newton's VBD cloth (PyPI `newton`).

Shared scene: a 0.3 m square sheet (the same triangle mesh for both), hanging vertically in the x-y plane, pinned at
its two top corners, relaxed under gravity to static equilibrium with the same material (HOOD's cotton by default).
Compared at equilibrium: the sag of the top edge's midpoint and of the sheet's centre below the pins, and the
max / mean distance between corresponding vertices.

Two processes exchange npz files, so newton never enters the project venv (it pins its own warp-lang):

    .venv/bin/python -m pleat.sim.crosscheck --newton-python out/venv-newton/bin/python --out out/crosscheck

runs the pleat side here and `python tools/pleat/sim/crosscheck.py --newton-side IN OUT` with the newton venv's
python (this file's top level imports only numpy, so it runs there without pleat installed).

Material conversion (docs/simulator.md, "Cross-check"):
- areal density m (kg/m²) → newton's `density` of add_cloth_mesh (per area; the same vertex masses m·A/3);
- μ, λ (2D Lamé, N/m) → tri_ke = μ, tri_ka = λ: newton's membrane is the 2D stable Neo-Hookean
  ψ = μ/2 (I_C − 2) + λ'/2 (J − α)² with λ' = λ + μ, α = 1 + μ/λ', per rest area; it has the same small-strain
  (linear) response as StVK with these μ, λ, and the hanging sheet's strains are ~1e-4, where the two agree;
- bending k (J): pleat's hinge energy is ½ k · 3ℓ²/(A₁+A₂) · (θ−θ̄)², newton's is ½ (ke_e ℓ_e)(θ−θ̄)², so each
  edge gets ke_e = k · 3ℓ_e/(A₁+A₂) (set per edge in model.edge_bending_properties);
- gravity 9.81 m/s² down (newton is Z-up: pleat (x, y, z) ↦ newton (x, −z, y));
- newton's damping (tri_kd, edge_kd) only speeds up settling; equilibrium does not depend on it.
"""
import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

SIZE_M = 0.3
GRID = 21


def make_scene(n=GRID, size=SIZE_M, height=1.0):
    """Vertices [n², 3] (pleat coordinates, Y up) of a vertical sheet, faces, the two pinned top corners."""
    from pleat.garment.sheet import grid_sheet                  # pleat side only (the newton side has no pleat)
    flat, faces = grid_sheet(n, n, size, size)                  # plane y = 0; its z rows become the sheet's height
    v = np.stack([flat[:, 0], height - (flat[:, 2] + 0.5 * size), np.zeros(len(flat))], axis=1)
    top = np.isclose(v[:, 1], height)
    pins = np.where(top & np.isclose(np.abs(v[:, 0]), 0.5 * size))[0]
    return v, faces, pins


def make_cantilever(nx=11, nz=5, length=0.1, width=0.04, height=1.0):
    """A horizontal strip (Y up) clamped along its x = 0 edge: it droops under gravity against its bending stiffness
    (a unique, bending-dominated equilibrium, unlike the hanging sheet, which barely deforms)."""
    from pleat.garment.sheet import grid_sheet
    v, faces = grid_sheet(nx, nz, length, width, height, center=(0.5 * length, 0.0))   # x from 0 to length
    pins = np.where(v[:, 0] <= length / (nx - 1) + 1e-9)[0]    # two rows: a clamp (one row would be a hinge)
    return v, faces, pins


def _to_newton(x):
    return np.stack([x[:, 0], -x[:, 2], x[:, 1]], axis=1)


def _from_newton(x):
    return np.stack([x[:, 0], x[:, 2], -x[:, 1]], axis=1)


# --------------------------------------------------------------------------------------------------------------
# newton side (runs in the newton venv: numpy, warp, newton only)

def newton_side(path_in, path_out, seconds=6.0, fps=60, substeps=10, iterations=20):
    import warp as wp
    import newton

    wp.config.quiet = True
    s = np.load(path_in)
    v, faces, pins = s["vertices"], s["faces"], s["pins"]
    m, mu, lam, k = (float(t) for t in s["material"])
    builder = newton.ModelBuilder()                 # Z up, gravity −9.81 m/s² along Z
    builder.add_cloth_mesh(pos=wp.vec3(0.0, 0.0, 0.0), rot=wp.quat_identity(), scale=1.0, vel=wp.vec3(0.0, 0.0, 0.0),
                           vertices=[wp.vec3(*p) for p in _to_newton(v)], indices=faces.ravel().tolist(), density=m,
                           tri_ke=mu, tri_ka=lam, tri_kd=float(s["tri_kd"]), edge_ke=1.0, edge_kd=float(s["edge_kd"]),
                           particle_radius=1e-3)
    for p in pins:
        builder.particle_mass[int(p)] = 0.0
    builder.color(include_bending=True)
    model = builder.finalize(device="cpu")
    # per-edge bending stiffness: ke_e ℓ_e = k · 3ℓ_e²/(A₁+A₂)
    e_idx = model.edge_indices.numpy()
    rest_len = model.edge_rest_length.numpy().astype(np.float64)
    props = model.edge_bending_properties.numpy()
    area = 0.5 * np.linalg.norm(np.cross(v[faces[:, 1]] - v[faces[:, 0]], v[faces[:, 2]] - v[faces[:, 0]]), axis=1)
    face_of = {}
    for fi, f in enumerate(faces):
        for a_, b_ in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0])):
            face_of.setdefault((min(a_, b_), max(a_, b_)), []).append(fi)
    n_interior = 0
    for ei, (o0, o1, a_, b_) in enumerate(e_idx):
        fs = face_of.get((min(a_, b_), max(a_, b_)), [])
        if o0 < 0 or o1 < 0 or len(fs) != 2:
            props[ei, 0] = 0.0
            continue
        props[ei, 0] = k * 3.0 * rest_len[ei] / (area[fs[0]] + area[fs[1]])
        n_interior += 1
    model.edge_bending_properties.assign(props.astype(np.float32))
    solver = newton.solvers.SolverVBD(model=model, iterations=iterations)
    state0, state1 = model.state(), model.state()
    if "start" in s.files:                       # start from the given state (pleat's equilibrium), at rest
        q = _to_newton(s["start"]).astype(np.float32)
        state0.particle_q.assign(q)
        state1.particle_q.assign(q)
    control = model.control()
    dt = 1.0 / fps / substeps
    t0 = time.perf_counter()
    history = []
    for frame in range(int(seconds * fps)):
        for _ in range(substeps):
            state0.clear_forces()
            solver.step(state0, state1, control, None, dt)
            state0, state1 = state1, state0
        if frame % fps == fps - 1:
            history.append(float(np.abs(state0.particle_qd.numpy()).max()))
    x = _from_newton(state0.particle_q.numpy().astype(np.float64))
    speed = float(np.linalg.norm(state0.particle_qd.numpy(), axis=1).max())
    np.savez(path_out, positions=x, max_speed=speed, seconds=time.perf_counter() - t0, interior_edges=n_interior,
             speed_history=np.array(history), version=np.array(newton.__version__),
             warp_version=np.array(wp.config.version), settings=np.array([seconds, fps, substeps, iterations]))


# --------------------------------------------------------------------------------------------------------------
# pleat side and comparison (project venv)

def pleat_side(v, faces, pins, material, steps=240, dt=1.0 / 30.0):
    from ..physics import cloth_rest
    from .solver import ClothSolver, SolverSettings
    # the force tolerance alone: a static comparison needs force balance (the velocity criterion would accept the
    # unsagged sheet, whose equilibrium stretch of a few µm is below 1e-3 m/s × h)
    solver = ClothSolver(cloth_rest(v, faces), material, pinned=pins,
                         settings=SolverSettings(dt_s=dt, max_newton=200, velocity_tol_m_s=0.0))
    x, x_prev = v.copy(), v.copy()
    t0 = time.perf_counter()
    for _ in range(steps):
        x_new, stats = solver.step(x, x_prev, pin_targets=v)
        x_prev, x = x, x_new
    # a last static solve: a huge step makes inertia negligible (the minimiser of elastic + gravity energy)
    static = ClothSolver(cloth_rest(v, faces), material, pinned=pins,
                         settings=SolverSettings(dt_s=1e3, max_newton=400, velocity_tol_m_s=0.0))
    x_static, st = static.step(x, x, pin_targets=v)
    return dict(positions=x_static, dynamic_end=x, seconds=time.perf_counter() - t0,
                last_step_speed=float(np.abs(x - x_prev).max() / dt),
                static_gradient_norm=st.gradient_norm,
                static_gradient_tolerance=static.settings.force_tol * static.weight_scale,
                static_converged=bool(st.converged),
                static_moved_m=float(np.abs(x_static - x).max()))


def _summary(x, v, pins):
    if np.isclose(v[:, 1], v[0, 1]).all():                      # the cantilever: droop of the free edge
        tip = np.isclose(v[:, 0], v[:, 0].max())
        return dict(tip_drop_m=float(v[tip, 1].mean() - x[tip, 1].mean()),
                    tip_pull_in_m=float(v[tip, 0].mean() - x[tip, 0].mean()))
    top_mid = np.argmin(np.abs(v[:, 0]) + np.abs(v[:, 1] - v[:, 1].max()))
    centre = np.argmin(np.abs(v[:, 0]) + np.abs(v[:, 1] - v[:, 1].mean()))
    pin_y = v[pins, 1].mean()
    return dict(top_mid_sag_m=float(pin_y - x[top_mid, 1]), centre_drop_m=float(v[centre, 1] - x[centre, 1]),
                lowest_m=float(pin_y - x[:, 1].min()), centre_out_of_plane_m=float(x[centre, 2]))


def main(argv=None):
    ap = argparse.ArgumentParser(description="pleat simulator vs newton VBD on a hanging sheet")
    ap.add_argument("--newton-side", nargs=2, metavar=("IN", "OUT"), help=argparse.SUPPRESS)
    ap.add_argument("--newton-python", default="out/venv-newton/bin/python")
    ap.add_argument("--out", default="out/crosscheck")
    ap.add_argument("--grid", type=int, default=GRID)
    ap.add_argument("--scene", choices=("sheet", "cantilever"), default="sheet")
    ap.add_argument("--bending", type=float, default=None, help="bending k (J) instead of the default material's")
    ap.add_argument("--newton-from-pleat", action="store_true",
                    help="start newton at pleat's equilibrium (at rest) and see whether it stays there")
    ap.add_argument("--reuse-newton", action="store_true", help="keep OUT/newton.npz from an earlier run of the same scene")
    ap.add_argument("--newton-seconds", type=float, default=4.0)
    ap.add_argument("--newton-iterations", type=int, default=20, help="VBD iterations per substep")
    ap.add_argument("--newton-substeps", type=int, default=10, help="VBD substeps per 1/60 s frame")
    args = ap.parse_args(argv)
    if args.newton_side:
        newton_side(*args.newton_side, seconds=args.newton_seconds, substeps=args.newton_substeps,
                    iterations=args.newton_iterations)
        return 0
    from ..physics import Material
    material = Material()
    if args.bending is not None:
        from dataclasses import replace
        material = replace(material, bending=float(args.bending))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    v, faces, pins = make_scene(args.grid) if args.scene == "sheet" else make_cantilever()
    scene = out / "scene.npz"
    extra = {}
    pl = None
    if args.newton_from_pleat:
        pl = pleat_side(v, faces, pins, material)
        extra["start"] = pl["positions"]
    np.savez(scene, vertices=v, faces=faces, pins=pins, material=np.array(material.as_tuple()),
             tri_kd=1e-2, edge_kd=1e-2, **extra)
    t0 = time.perf_counter()
    if args.reuse_newton and (out / "newton.npz").exists():
        proc = subprocess.CompletedProcess([], 0, "", "")
    else:
        proc = subprocess.run([args.newton_python, str(Path(__file__).resolve()), "--newton-side", str(scene),
                               str(out / "newton.npz"), "--newton-seconds", str(args.newton_seconds),
                               "--newton-iterations", str(args.newton_iterations),
                               "--newton-substeps", str(args.newton_substeps)],
                              capture_output=True, text=True)
    result = dict(scene=dict(kind=args.scene, size_m=SIZE_M if args.scene == "sheet" else 0.1, grid=args.grid, vertices=len(v), faces=len(faces), pins=pins.tolist()),
                  material=dict(zip(("m", "mu", "lambda", "k"), material.as_tuple())))
    if proc.returncode != 0:
        result["newton_error"] = (proc.stderr or proc.stdout)[-4000:]
        print(result["newton_error"], file=sys.stderr)
    if pl is None:
        pl = pleat_side(v, faces, pins, material)
    result["newton_started_from_pleat"] = bool(args.newton_from_pleat)
    result["pleat"] = dict(_summary(pl["positions"], v, pins), seconds=pl["seconds"],
                           **{k: pl[k] for k in ("last_step_speed", "static_gradient_norm", "static_gradient_tolerance",
                                                 "static_converged", "static_moved_m")})
    if proc.returncode == 0:
        nw = np.load(out / "newton.npz")
        xn = nw["positions"]
        d = np.linalg.norm(xn - pl["positions"], axis=1)
        result["newton"] = dict(_summary(xn, v, pins), version=str(nw["version"]), warp=str(nw["warp_version"]),
                                seconds=float(nw["seconds"]), wall_seconds=time.perf_counter() - t0,
                                final_max_speed_m_s=float(nw["max_speed"]),
                                speed_history=nw["speed_history"].tolist(), interior_edges=int(nw["interior_edges"]),
                                settings=dict(zip(("seconds", "fps", "substeps", "iterations"),
                                                  nw["settings"].tolist())))
        result["difference"] = dict(max_vertex_distance_m=float(d.max()), mean_vertex_distance_m=float(d.mean()),
                                    **{f"{k[:-2]}_diff_m": result["newton"][k] - result["pleat"][k]
                                       for k in result["pleat"] if k.endswith("_m") and k in result["newton"]})
        np.savez(out / "positions.npz", pleat=pl["positions"], newton=xn, rest=v, faces=faces)
    (out / "crosscheck.json").write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
