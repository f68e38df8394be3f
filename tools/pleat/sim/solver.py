"""Implicit Euler cloth step: minimise the incremental potential with Newton, line search and a sparse direct solve.

Each step solves   x_{t+1} = argmin_x  inertia + gravity + stretching + bending + collision + friction
(the terms of `pleat.physics`, all with weight 1) over the free vertices; pinned vertices are set to their targets
(the garment skinned onto the body by LBS). Element Hessians are PSD (StVK projected per face in F-space, bending
Gauss-Newton, collision and friction PSD by construction), so each Newton direction is a descent direction; a
backtracking (Armijo) line search keeps the energy monotone. Converged when the largest residual force on a free
vertex is below `force_tol` times the heaviest vertex weight (default 1e-3: a thousandth of a vertex's weight) or
when a full Newton update moves no vertex more than `step_tol_m` (1e-5 m).
Collisions use the posed body at t+1 from the step's start positions, re-queried after the solve (up to
`contact_rounds` times) if a vertex ended closer than the margin to a body point it was not tested against; a final
projection puts any vertex still below the body surface (d < 0) back onto it.
"""
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ..physics import energies as en


@dataclass
class SolverSettings:
    dt_s: float = 1.0 / 30.0
    collision_margin_m: float = 4e-3      # ε: penalty starts below this distance to the body
    collision_stiffness: float = 1e6      # κ in κ·max(ε−d,0)³, J/m³
    friction: float = 0.3                 # μ_f
    friction_eps_m: float = 1e-3          # ε_u: Huber smoothing of the tangential slip per step
    force_tol: float = 1e-3               # converged: residual ‖∇E‖∞ ≤ force_tol · max_i(m_i g), or
    step_tol_m: float = 1e-5              # the Newton step moves no vertex more than this (0.01 mm)
    max_newton: int = 25
    contact_rounds: int = 1
    penetration_tol_m: float = 1e-3       # stated tolerance: no free vertex deeper than this after a step


@dataclass
class StepStats:
    newton_iterations: int = 0
    gradient_norm: float = 0.0            # ‖∇E‖∞ over free DOFs at the end, N
    energies: list = field(default_factory=list)   # total energy after each accepted Newton iteration
    penetration_before_projection_m: float = 0.0
    converged: bool = False


class _Pattern:
    """Fixed CSR sparsity over the free DOFs, with a scatter map from element-block entries to CSR slots."""

    def __init__(self, n_vertices, free_dof_index, blocks):
        rows, cols = [], []
        for verts in blocks:                         # verts [M, k]
            k = verts.shape[1]
            d = (3 * verts[:, :, None] + np.arange(3)).reshape(len(verts), 3 * k)   # [M, 3k] global dofs
            d = free_dof_index[d]
            rows.append(np.repeat(d, 3 * k, axis=1).ravel())
            cols.append(np.tile(d, (1, 3 * k)).ravel())
        rows = np.concatenate(rows)
        cols = np.concatenate(cols)
        self.keep = (rows >= 0) & (cols >= 0)
        self.n = int(free_dof_index.max()) + 1
        key = rows[self.keep].astype(np.int64) * self.n + cols[self.keep]
        uniq, self.inverse = np.unique(key, return_inverse=True)
        self.indices = (uniq % self.n).astype(np.int32)
        self.indptr = np.concatenate([[0], np.cumsum(np.bincount(uniq // self.n, minlength=self.n))]).astype(np.int32)
        self.nnz = len(uniq)

    def matrix(self, values):
        data = np.bincount(self.inverse, weights=values[self.keep], minlength=self.nnz)
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))


class ClothSolver:
    def __init__(self, rest, material, pinned=None, settings=None):
        self.rest = rest
        self.material = material
        self.settings = settings or SolverSettings()
        n = len(rest.vertex_area)
        self.n = n
        self.mass = material.density_kg_m2 * rest.vertex_area
        self.pinned = np.zeros(n, bool)
        if pinned is not None and len(pinned):
            self.pinned[np.asarray(pinned, np.int64)] = True
        free_dof = np.repeat(~self.pinned, 3)
        self.free_dof_index = np.full(3 * n, -1, np.int64)
        self.free_dof_index[free_dof] = np.arange(free_dof.sum())
        self.free_dof = free_dof
        verts = np.arange(n)[:, None]
        self.pattern = _Pattern(n, self.free_dof_index, [rest.faces, rest.hinges, verts])
        self.weight_scale = float(self.mass.max() * en.GRAVITY_M_S2)

    # -- energy of the step -------------------------------------------------------------------------------------
    def _terms(self, x, c):
        m = self.material
        s = self.settings
        e = (en.inertia_energy(x, c["x_pred"], self.mass, s.dt_s) + en.gravity_energy(x, self.mass)
             + en.stretching_energy(x, self.rest, m.mu, m.lam) + en.bending_energy(x, self.rest, m.bending))
        if c["p"] is not None:
            e += en.collision_energy(x, c["p"], c["n"], s.collision_margin_m, s.collision_stiffness)
            e += en.friction_energy(x, c["x_t"], c["body_disp"], c["n"], c["lam"], s.friction, s.friction_eps_m)
        return float(e)

    def _grad_hess(self, x, c):
        m = self.material
        s = self.settings
        inv_dt2 = 1.0 / (s.dt_s * s.dt_s)
        g = (self.mass * inv_dt2)[:, None] * (x - c["x_pred"])
        g[:, 1] += self.mass * en.GRAVITY_M_S2
        diag = (self.mass * inv_dt2)[:, None, None] * np.eye(3)
        gs, hs = en.stretching_grad_hess(x, self.rest, m.mu, m.lam)
        gb, hb = en.bending_grad_hess(x, self.rest, m.bending)
        g += gs + gb
        if c["p"] is not None:
            gc, hc = en.collision_grad_hess(x, c["p"], c["n"], s.collision_margin_m, s.collision_stiffness)
            gf, hf = en.friction_grad_hess(x, c["x_t"], c["body_disp"], c["n"], c["lam"], s.friction,
                                           s.friction_eps_m)
            g += gc + gf
            diag = diag + hc + hf
        values = np.concatenate([hs.ravel(), hb.ravel(), diag.ravel()])
        return g, self.pattern.matrix(values)

    def _contacts(self, x, x_t, body_t, body_next):
        if body_next is None:
            return dict(p=None)
        s = self.settings
        idx, p, n, d = body_next.query(x)
        gap = np.maximum(s.collision_margin_m - d, 0.0)
        gap[self.pinned] = 0.0
        lam = 3.0 * s.collision_stiffness * gap * gap          # normal force, lagged over the step
        disp = p - body_t.vertices[idx] if body_t is not None else np.zeros_like(p)
        n = np.where(self.pinned[:, None], 0.0, n)              # pinned vertices feel no contact
        return dict(p=p, n=n, lam=lam, body_disp=disp, idx=idx)

    # -- one step ------------------------------------------------------------------------------------------------
    def step(self, x_t, x_prev, pin_targets=None, body_t=None, body_next=None):
        """x_{t+1} from x_t, x_{t−1}; body_t/body_next: BodyCollider at t and t+1 (or None for no body)."""
        s = self.settings
        x_t = np.asarray(x_t, np.float64)
        x_pred = 2.0 * x_t - np.asarray(x_prev, np.float64)
        x = x_pred.copy()
        if pin_targets is not None:
            x[self.pinned] = np.asarray(pin_targets, np.float64)[self.pinned]
        stats = StepStats()
        c = self._contacts(x_t, x_t, body_t, body_next)
        c.update(x_pred=x_pred, x_t=x_t)
        for rnd in range(max(1, s.contact_rounds)):
            x = self._newton(x, c, stats)
            if body_next is None or rnd + 1 == s.contact_rounds:
                break
            idx, _, _, d = body_next.query(x)
            moved = (idx != c["idx"]) & (d < s.collision_margin_m) & ~self.pinned
            if not moved.any():
                break
            # re-test against the body points nearest to where the vertices ended (normal force from there too)
            c.update(self._contacts(x, x_t, body_t, body_next))
        if body_next is not None:
            # project onto the tangent plane of the nearest body vertex; repeat, since a projected vertex can get a
            # new nearest vertex (concave regions: armpits, crotch)
            for k in range(5):
                _, _, n, d = body_next.query(x)
                inside = (d < 0.0) & ~self.pinned
                if k == 0:
                    stats.penetration_before_projection_m = float(-d[inside].min()) if inside.any() else 0.0
                if not inside.any():
                    break
                x[inside] -= d[inside, None] * n[inside]
        return x, stats

    def _newton(self, x, c, stats):
        s = self.settings
        tol = s.force_tol * self.weight_scale
        energy = self._terms(x, c)
        for _ in range(s.max_newton):
            g, H = self._grad_hess(x, c)
            gf = g.ravel()[self.free_dof]
            stats.gradient_norm = float(np.abs(gf).max()) if gf.size else 0.0
            if stats.gradient_norm <= tol:
                stats.converged = True
                return x
            try:
                # SPD system: symmetric mode without pivoting keeps SuperLU's fill (and time) ~10x lower
                dx = splu(H.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                          options=dict(SymmetricMode=True)).solve(-gf)
            except RuntimeError:                            # singular: fall back to a scaled gradient step
                dx = -gf / (H.diagonal() + 1e-12)
            full = np.zeros(3 * self.n)
            full[self.free_dof] = dx
            full = full.reshape(-1, 3)
            slope = float(gf @ dx)
            alpha = 1.0
            while True:
                trial = x + alpha * full
                e_trial = self._terms(trial, c)
                if e_trial <= energy + 1e-4 * alpha * slope or alpha < 1e-6:
                    break
                alpha *= 0.5
            if e_trial > energy:                            # no decrease possible at round-off level: done
                stats.converged = stats.gradient_norm <= 10 * tol
                return x
            x, energy = trial, e_trial
            stats.newton_iterations += 1
            stats.energies.append(energy)
            if alpha * np.abs(full).max() < s.step_tol_m:
                g, _ = self._grad_hess(x, c)
                stats.gradient_norm = float(np.abs(g.ravel()[self.free_dof]).max())
                stats.converged = True
                return x
        g, _ = self._grad_hess(x, c)
        stats.gradient_norm = float(np.abs(g.ravel()[self.free_dof]).max())
        stats.converged = stats.gradient_norm <= tol
        return x
