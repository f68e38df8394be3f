"""Cross-check of the reference simulator against an independent open simulator: newton's VBD cloth (PyPI `newton`).

Shared scenes (the same triangle mesh and material for both): a 0.3 m square sheet hanging in the x-y plane from its
two top corners (membrane, gravity, pins), and a 0.1 m × 0.04 m cantilever strip clamped along one end (bending).
Compared at equilibrium: sags / the tip's drop and pull-in, and the max / mean distance between corresponding
vertices. `--static` (cantilever) steps nothing: both codes' per-vertex bending, membrane and gravity forces on the
same configurations, one VBD substep from pleat's equilibrium per iteration count, and pleat's equilibrium against
beam theory with its hinge energy's effective plate stiffness (docs/crosscheck.md).

Two processes exchange npz files, so newton never enters the project venv (it pins its own warp-lang):

    .venv/bin/python -m pleat.sim.crosscheck --newton-python out/venv-newton/bin/python --out out/crosscheck

runs the pleat side here and `python tools/pleat/sim/crosscheck.py --newton-side IN OUT` (or --newton-forces,
--newton-first-step) with the newton venv's python (this file's top level imports only numpy, so it runs there
without pleat installed).

Material conversion (docs/crosscheck.md):
- areal density m (kg/m²) → newton's `density` of add_cloth_mesh (per area; the same vertex masses m·A/3);
- μ, λ (2D Lamé, N/m) → tri_ke = μ, tri_ka = λ: newton's membrane is the 2D stable Neo-Hookean
  ψ = μ/2 (I_C − 2) + λ'/2 (J − α)² with λ' = λ + μ, α = 1 + μ/λ', per rest area; it has the same small-strain
  (linear) response as StVK with these μ, λ (forces equal to 0.1 % at strains ≤ 1e-3, measured by --static);
- bending k (J): pleat's hinge energy is ½ k · 3ℓ²/(A₁+A₂) · (θ−θ̄)², newton's is ½ (ke_e ℓ_e)(θ−θ̄)², so each
  edge gets ke_e = k · 3ℓ_e/(A₁+A₂) (set per edge in model.edge_bending_properties; per-vertex bending forces equal
  to 2e-7 relative, measured by --static);
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

try:
    from pleat.cli import add_quiet, command
except ImportError:      # the newton side runs this file as a script in newton's own venv, where pleat is absent
    def command(prog, build_parser):
        return lambda main: lambda argv=None: main(build_parser().parse_args(argv))

    def add_quiet(parser):
        return parser

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

def _newton_model(s):
    """newton's model of the scene npz `s`: pleat's mesh, material conversion and pins (see the module docstring)."""
    import warp as wp
    import newton

    wp.config.quiet = True
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
    props[:, 0] = bending_ke(v, faces, e_idx, rest_len, k)
    model.edge_bending_properties.assign(props.astype(np.float32))
    return model, int(np.count_nonzero(props[:, 0]))


def bending_ke(v, faces, edge_indices, edge_length, k):
    """newton's per-edge `edge_ke` for pleat's hinge energy: ke_e = k · 3ℓ_e/(A₁+A₂) on interior edges, 0 on the
    boundary. newton's edge (o0, o1, a, b) has its hinge on a→b and stores ℓ_e (`edge_rest_length`) itself."""
    area = 0.5 * np.linalg.norm(np.cross(v[faces[:, 1]] - v[faces[:, 0]], v[faces[:, 2]] - v[faces[:, 0]]), axis=1)
    face_of = {}
    for fi, f in enumerate(faces):
        for a_, b_ in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0])):
            face_of.setdefault((min(a_, b_), max(a_, b_)), []).append(fi)
    ke = np.zeros(len(edge_indices))
    for ei, (o0, o1, a_, b_) in enumerate(edge_indices):
        fs = face_of.get((min(a_, b_), max(a_, b_)), [])
        if o0 >= 0 and o1 >= 0 and len(fs) == 2:
            ke[ei] = k * 3.0 * edge_length[ei] / (area[fs[0]] + area[fs[1]])
    return ke


def newton_forces(path_in, path_out):
    """newton's own per-vertex forces on given configurations, without stepping: its VBD kernels' membrane and
    dihedral bending functions (the ones its solver calls per vertex) launched once per element and vertex, damping
    off, summed per vertex; plus gravity m_i g. IN holds the scene and `configs` [C, N, 3] (pleat coordinates)."""
    import warp as wp
    from newton._src.solvers.vbd.particle_vbd_kernels import (
        evaluate_dihedral_angle_based_bending_force_hessian as bending_force_hessian,
        evaluate_neo_hookean_membrane_force_hessian as membrane_force_hessian)

    @wp.kernel
    def bending_forces(pos: wp.array(dtype=wp.vec3), edges: wp.array2d(dtype=wp.int32),
                       rest_angle: wp.array(dtype=float), rest_length: wp.array(dtype=float),
                       props: wp.array2d(dtype=float), out: wp.array(dtype=wp.vec3)):
        tid = wp.tid()
        e = tid // 4
        order = tid - 4 * e
        if props[e, 0] > 0.0:
            f, h = bending_force_hessian(e, order, pos, pos, edges, rest_angle, rest_length, props[e, 0], 0.0, 1.0)
            wp.atomic_add(out, edges[e, order], f)

    @wp.kernel
    def membrane_forces(pos: wp.array(dtype=wp.vec3), tris: wp.array2d(dtype=wp.int32),
                        poses: wp.array(dtype=wp.mat22), areas: wp.array(dtype=float),
                        materials: wp.array2d(dtype=float), out: wp.array(dtype=wp.vec3)):
        tid = wp.tid()
        t = tid // 3
        order = tid - 3 * t
        f, h = membrane_force_hessian(t, order, pos, pos, tris, poses[t], areas[t], materials[t, 0],
                                      materials[t, 1], 0.0, 1.0)
        wp.atomic_add(out, tris[t, order], f)

    s = np.load(path_in)
    model, _ = _newton_model(s)
    n = model.particle_count
    gravity = np.array(model.gravity.numpy()).reshape(-1, 3)[0].astype(np.float64)
    out = dict(bending=[], membrane=[], positions32=[])
    for x in s["configs"]:
        pos = wp.array(_to_newton(x).astype(np.float32), dtype=wp.vec3, device="cpu")
        for name, kernel, dim, inputs in (
                ("bending", bending_forces, 4 * model.edge_count,
                 [model.edge_indices, model.edge_rest_angle, model.edge_rest_length, model.edge_bending_properties]),
                ("membrane", membrane_forces, 3 * model.tri_count,
                 [model.tri_indices, model.tri_poses, model.tri_areas, model.tri_materials])):
            f = wp.zeros(n, dtype=wp.vec3, device="cpu")
            wp.launch(kernel, dim=dim, inputs=[pos, *inputs, f], device="cpu")
            out[name].append(_from_newton(f.numpy().astype(np.float64)))
        out["positions32"].append(_from_newton(pos.numpy().astype(np.float64)))
    mass = model.particle_mass.numpy().astype(np.float64)
    np.savez(path_out, bending=np.array(out["bending"]), membrane=np.array(out["membrane"]),
             positions32=np.array(out["positions32"]), gravity=_from_newton(mass[:, None] * gravity[None, :]),
             edge_ke=model.edge_bending_properties.numpy()[:, 0], edge_indices=model.edge_indices.numpy(),
             edge_rest_angle=model.edge_rest_angle.numpy())


def newton_first_step(path_in, path_out, iterations=(1, 10, 100, 1000, 10000, 50000), fps=60, substeps=10):
    """One VBD substep from the given start (pleat's equilibrium) at rest, for each iteration count: the exact
    implicit-Euler step from an equilibrium does not move, so the displacement left is VBD's unconverged part
    (g·dt² everywhere if the iterations did nothing)."""
    import newton

    s = np.load(path_in)
    model, _ = _newton_model(s)
    start = _to_newton(s["start"]).astype(np.float32)
    moved = []
    for it in iterations:
        solver = newton.solvers.SolverVBD(model=model, iterations=int(it))
        state0, state1 = model.state(), model.state()
        state0.particle_q.assign(start)
        state1.particle_q.assign(start)
        state0.clear_forces()
        solver.step(state0, state1, model.control(), None, 1.0 / fps / substeps)
        moved.append(_from_newton(state1.particle_q.numpy().astype(np.float64) - start.astype(np.float64)))
    np.savez(path_out, iterations=np.array(iterations), displacement=np.array(moved), dt=1.0 / fps / substeps)


def newton_side(path_in, path_out, seconds=6.0, fps=60, substeps=10, iterations=20):
    import warp as wp
    import newton

    s = np.load(path_in)
    model, n_interior = _newton_model(s)
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


# --------------------------------------------------------------------------------------------------------------
# static checks: the same configurations in both codes (no dynamics), and pleat's hinge energy against plate theory

def cylinder_bend(v, kappa, along=0, start=None):
    """A flat sheet (plane y = const) bent without stretching into a cylinder of curvature kappa (1/m) that curls
    down along coordinate `along` (0: x, 2: z; or a unit vector in the x-z plane) from the line s = start on."""
    d = np.eye(3)[along] if np.isscalar(along) else np.asarray(along, np.float64)
    s = v @ d
    s0 = s.min() if start is None else start
    t = np.maximum(s - s0, 0.0)
    x = v + d[None, :] * (np.sin(kappa * t) / kappa - t)[:, None]
    x[:, 1] -= (1.0 - np.cos(kappa * t)) / kappa
    return x


def hinge_bending_stiffness(k, kappa=2.0, along=0, spacing=0.01, sizes=(9, 13, 17, 21)):
    """Effective plate bending stiffness D_eff (J) of pleat's hinge energy on grid_sheet meshes: a cylinder of
    curvature κ stores ½ D_eff κ² per area. Fitted over square sheets of the same spacing as E = a·A + b·√A + c, so
    the boundary (whose edges have no hinge) drops out: D_eff = 2a/κ²."""
    from pleat.garment.sheet import grid_sheet
    from pleat.physics import bending_energy, cloth_rest
    energy, area = [], []
    for n in sizes:
        v, f = grid_sheet(n, n, (n - 1) * spacing, (n - 1) * spacing)
        rest = cloth_rest(v, f)
        energy.append(bending_energy(cylinder_bend(v, kappa, along), rest, k))
        area.append(rest.face_area.sum())
    area = np.array(area)
    a = np.linalg.lstsq(np.stack([area, np.sqrt(area), np.ones_like(area)], 1), np.array(energy), rcond=None)[0][0]
    return 2.0 * a / kappa ** 2


def cantilever_theory(q_n_m2, bending_stiffness, length, segments=None):
    """Tip drop and pull-in (m) of an inextensible clamped strip under its own weight q (N/m² of area) with plate
    stiffness D (J): Euler–Bernoulli's linear δ = qL⁴/(8D), the large-deflection elastica (shooting on
    D θ'' = −q (L − s) cos θ, θ(0) = 0, θ'(L) = 0), and, with `segments`, the same strip as a chain of that many
    rigid segments with hinges of stiffness D/h and lumped masses (the 1D reduction of pleat's grid on this mesh)."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import brentq, root
    a = q_n_m2 / bending_stiffness

    def shoot(slope0):
        return solve_ivp(lambda s, y: [y[1], -a * (length - s) * np.cos(y[0]), np.cos(y[0]), np.sin(y[0])],
                         (0.0, length), [0.0, slope0, 0.0, 0.0], rtol=1e-10, atol=1e-12).y[:, -1]
    end = shoot(brentq(lambda t: shoot(t)[1], 0.0, 10.0 * a * length ** 2))
    out = dict(euler_bernoulli_tip_drop_m=q_n_m2 * length ** 4 / (8.0 * bending_stiffness),
               elastica_tip_drop_m=float(end[3]), elastica_tip_pull_in_m=float(length - end[2]))
    if segments:
        h = length / segments
        load = np.full(segments, q_n_m2 * h)
        load[-1] *= 0.5                                          # per unit width; the tip row has half the area
        hinge = bending_stiffness / h

        def stationarity(phi):                                   # ∂E/∂φ / hinge, E = Σ ½ hinge Δφ² + Σ load·y
            turn = np.diff(np.concatenate([[0.0], phi]))
            return (turn - np.concatenate([turn[1:], [0.0]])
                    - np.cos(phi) * h * np.cumsum(load[::-1])[::-1] / hinge)
        phi = root(stationarity, np.zeros(segments), method="hybr", tol=1e-14).x
        out.update(chain_tip_drop_m=float(h * np.sin(phi).sum()),
                   chain_tip_pull_in_m=float(length - h * np.cos(phi).sum()))
    return out


def static_force_configs(v, pins, equilibrium):
    """Named configurations [N, 3] of the cantilever for the static force comparison."""
    clamp = v[pins, 0].max()
    rng = np.random.default_rng(0)
    bump = np.zeros_like(v)
    bump[:, 1] = 5e-4 * rng.standard_normal(len(v))
    return {"rest": v,
            "pleat equilibrium": equilibrium,
            "pleat equilibrium at height 0": equilibrium - np.array([0.0, v[0, 1], 0.0]),
            "cylinder along x, κ = 5/m": cylinder_bend(v, 5.0, 0, start=clamp),
            "cylinder along z, κ = 5/m": cylinder_bend(v, 5.0, 2),
            "cylinder along the diagonal, κ = 5/m": cylinder_bend(v, 5.0, np.array([1.0, 0.0, 1.0]) / np.sqrt(2.0)),
            "random out-of-plane, 0.5 mm": v + bump,
            "stretch 1e-3 along x": v * np.array([1.0 + 1e-3, 1.0, 1.0]),
            "shear 1e-3": v + np.stack([1e-3 * v[:, 2], np.zeros(len(v)), np.zeros(len(v))], 1)}


def compare_static_forces(v, faces, pins, material, equilibrium, newton_python, out):
    """pleat's and newton's bending, membrane and gravity forces per vertex on the same configurations."""
    from ..physics import GRAVITY_M_S2, bending_grad_hess, cloth_rest, stretching_grad_hess_gn
    configs = static_force_configs(v, pins, equilibrium)
    scene = out / "static_scene.npz"
    np.savez(scene, vertices=v, faces=faces, pins=pins, material=np.array(material.as_tuple()), tri_kd=1e-2,
             edge_kd=1e-2, configs=np.array(list(configs.values())))
    proc = subprocess.run([newton_python, str(Path(__file__).resolve()), "--newton-forces", str(scene),
                           str(out / "static_newton.npz")], capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr[-4000:])
    nw = np.load(out / "static_newton.npz")
    m, mu, lam, k = material.as_tuple()
    rest = cloth_rest(v, faces)
    rest32 = cloth_rest(v.astype(np.float32).astype(np.float64), faces)   # newton's rest shape (float32 input)
    free = np.setdiff1d(np.arange(len(v)), pins)
    weight = m * rest.vertex_area * GRAVITY_M_S2
    gravity = np.zeros_like(v)
    gravity[:, 1] = -weight

    def rel(a, b):
        return dict(pleat_max_N=float(np.abs(a).max()), newton_max_N=float(np.abs(b).max()),
                    max_difference_N=float(np.abs(a - b).max()),
                    least_squares_ratio=float(np.sum(a * b) / np.sum(a * a)) if np.abs(a).max() > 0 else None)
    rows = {}
    for i, (name, x) in enumerate(configs.items()):
        x32 = nw["positions32"][i]
        pb = -bending_grad_hess(x32, rest32, k)[0]
        pm = -stretching_grad_hess_gn(x32, rest32, mu, lam)[0]
        pm64 = -stretching_grad_hess_gn(x, rest, mu, lam)[0]
        net64 = -bending_grad_hess(x, rest, k)[0] + pm64 + gravity
        nb, nm = nw["bending"][i], nw["membrane"][i]
        rows[name] = dict(bending=rel(pb[free], nb[free]), membrane=rel(pm[free], nm[free]),
                          membrane_float32_rounding_N=float(np.abs(pm64 - pm)[free].max()),
                          pleat_net_force_float64_N=float(np.abs(net64)[free].max()),
                          newton_net_force_N=float(np.abs(nb + nm + nw["gravity"])[free].max()))
    result = dict(max_vertex_weight_N=float(weight[free].max()),
                  gravity_max_difference_N=float(np.abs(nw["gravity"] - gravity)[free].max()),
                  newton_rest_angle_max_rad=float(np.abs(nw["edge_rest_angle"]).max()), configurations=rows)
    _write_json(out / "static_forces.json", result)
    return result


def _write_json(path, result):
    """A report of the pleat side, atomically (pleat.fileio; imported here: the newton side has no pleat)."""
    from pleat.fileio import write_text
    write_text(path, json.dumps(result, indent=2) + "\n")


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


def first_substep(v, faces, pins, material, equilibrium, args, out):
    """newton's VBD, one substep from pleat's equilibrium at rest: the tip's drop per iteration count."""
    scene = out / "first_step_scene.npz"
    np.savez(scene, vertices=v, faces=faces, pins=pins, material=np.array(material.as_tuple()),
             tri_kd=args.newton_damping, edge_kd=args.newton_damping, start=equilibrium)
    proc = subprocess.run([args.newton_python, str(Path(__file__).resolve()), "--newton-first-step", str(scene),
                           str(out / "first_step_newton.npz"), "--first-step-iterations", args.first_step_iterations,
                           "--newton-substeps", str(args.newton_substeps)],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr[-4000:])
    nw = np.load(out / "first_step_newton.npz")
    tip = np.isclose(v[:, 0], v[:, 0].max())
    free = np.setdiff1d(np.arange(len(v)), pins)
    dt = float(nw["dt"])
    return dict(substep_s=dt, free_fall_drop_m=9.81 * dt * dt,
                rows=[dict(iterations=int(it), tip_drop_m=float(-d[tip, 1].mean()),
                           max_displacement_m=float(np.linalg.norm(d[free], axis=1).max()))
                      for it, d in zip(nw["iterations"], nw["displacement"])])


def static_main(v, faces, pins, material, args, out):
    from ..physics import GRAVITY_M_S2
    pl = pleat_side(v, faces, pins, material)
    k = material.bending
    d_eff = {name: hinge_bending_stiffness(k, along=a) for name, a in
             (("x", 0), ("z", 2), ("diagonal", np.array([1.0, 0.0, 1.0]) / np.sqrt(2.0)))}
    clamp = v[pins, 0].max()
    length = v[:, 0].max() - clamp
    segments = int(round(length / (v[:, 0].max() / (len(np.unique(v[:, 0])) - 1))))
    result = dict(material=dict(zip(("m", "mu", "lambda", "k"), material.as_tuple())),
                  pleat=dict(_summary(pl["positions"], v, pins), static_gradient_norm=pl["static_gradient_norm"],
                             static_converged=pl["static_converged"]),
                  hinge_d_eff_over_k={name: d / k for name, d in d_eff.items()},
                  theory_with_d_eff_x=cantilever_theory(material.density_kg_m2 * GRAVITY_M_S2, d_eff["x"], length,
                                                         segments=segments),
                  free_length_m=float(length))
    result["forces"] = compare_static_forces(v, faces, pins, material, pl["positions"], args.newton_python, out)
    result["first_substep"] = first_substep(v, faces, pins, material, pl["positions"], args, out)
    _write_json(out / "static.json", result)
    print(json.dumps(result, indent=2))
    return 0


def build_parser():
    ap = argparse.ArgumentParser(prog="pleat-crosscheck",
                                 description="pleat simulator vs newton VBD on a hanging sheet or a cantilever")
    ap.add_argument("--newton-side", nargs=2, metavar=("IN", "OUT"), help=argparse.SUPPRESS)
    ap.add_argument("--newton-forces", nargs=2, metavar=("IN", "OUT"), help=argparse.SUPPRESS)
    ap.add_argument("--newton-first-step", nargs=2, metavar=("IN", "OUT"), help=argparse.SUPPRESS)
    ap.add_argument("--newton-python", default="out/venv-newton/bin/python",
                    help="python of a venv with newton and warp installed (the newton side runs there)")
    ap.add_argument("--out", default="out/crosscheck",
                    help="output folder (crosscheck.json, scene.npz, newton.npz, positions.npz)")
    ap.add_argument("--grid", type=int, default=GRID, help="sheet: vertices per side")
    ap.add_argument("--scene", choices=("sheet", "cantilever"), default="sheet",
                    help="a hanging sheet pinned at two corners, or a cantilever strip")
    ap.add_argument("--bending", type=float, default=None, help="bending k (J) instead of the default material's")
    ap.add_argument("--newton-from-pleat", action="store_true",
                    help="start newton at pleat's equilibrium (at rest) and see whether it stays there")
    ap.add_argument("--reuse-newton", action="store_true", help="keep OUT/newton.npz from an earlier run of the same scene")
    ap.add_argument("--newton-seconds", type=float, default=4.0, help="simulated time of the newton side, s")
    ap.add_argument("--newton-iterations", type=int, default=20, help="VBD iterations per substep")
    ap.add_argument("--newton-substeps", type=int, default=10, help="VBD substeps per 1/60 s frame")
    ap.add_argument("--newton-damping", type=float, default=1e-2,
                    help="newton's tri_kd and edge_kd (its bending damping force is edge_kd·ℓ_e·dθ/dt along ∇θ)")
    ap.add_argument("--height", type=float, default=1.0, help="height (m) of the scene's top edge / strip")
    ap.add_argument("--static", action="store_true",
                    help="cantilever, no stepping: both codes' forces on the same configurations (OUT/static_forces"
                         ".json) and pleat's equilibrium against beam theory with its hinge energy's D_eff")
    ap.add_argument("--first-step-iterations", default="1,10,100,1000,10000,50000",
                    help="with --static: VBD iteration counts of the one-substep test from pleat's equilibrium")
    return add_quiet(ap)


@command("pleat-crosscheck", build_parser)
def main(args):
    if args.newton_forces:
        newton_forces(*args.newton_forces)
        return 0
    if args.newton_first_step:
        newton_first_step(*args.newton_first_step, iterations=[int(t) for t in args.first_step_iterations.split(",")],
                          substeps=args.newton_substeps)
        return 0
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
    v, faces, pins = (make_scene(args.grid, height=args.height) if args.scene == "sheet"
                      else make_cantilever(height=args.height))
    if args.static:
        return static_main(v, faces, pins, material, args, out)
    scene = out / "scene.npz"
    extra = {}
    pl = None
    if args.newton_from_pleat:
        pl = pleat_side(v, faces, pins, material)
        extra["start"] = pl["positions"]
    np.savez(scene, vertices=v, faces=faces, pins=pins, material=np.array(material.as_tuple()),
             tri_kd=args.newton_damping, edge_kd=args.newton_damping, **extra)
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
        from pleat.fileio import save_npz
        save_npz(out / "positions.npz", pleat=pl["positions"], newton=xn, rest=v, faces=faces)
    _write_json(out / "crosscheck.json", result)
    print(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
