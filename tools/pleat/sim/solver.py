"""Implicit Euler cloth step: minimise the incremental potential with inexact Newton (preconditioned CG), line search.

A frame step of dt is split into K substeps of h = dt/K; the body is interpolated linearly between the two frames
and K is chosen so that, near the garment, the body surface moves at most `max_body_step_m` per substep relative to
the garment's predicted motion. Each substep solves

    x = argmin_x  inertia(h) + gravity + stretching + bending + collision + friction

(the terms of `pleat.physics`, all with weight 1) over the free vertices; pinned vertices follow their targets (the
garment skinned onto the body by LBS, interpolated like the body). Element Hessians are PSD (StVK: Gauss-Newton plus
the clamped stress term, bending Gauss-Newton, collision and friction PSD by construction); the Newton system (3×3
blocks, `blocksparse`) is solved by conjugate gradients preconditioned by block IC(0) in reverse Cuthill–McKee order
to a relative residual η, and a backtracking (Armijo) line search keeps the energy monotone for fixed contacts.

Converged (the stated tolerance, docs/simulator.md "Converged") when the largest residual force on a free vertex,
‖∇E‖∞, is at most `force_tol` times the heaviest vertex weight max_i m_i g, or when the Newton step of an
untruncated CG solve has ‖Δx‖∞/h ≤ `velocity_tol_m_s` (IPC's criterion); a substep that reaches `max_newton` is
reported as not converged.

Contacts are fixed during a substep's solve: each vertex takes the body vertex nearest to it at the substep's start,
moved with the body to the substep's end, so a limb that sweeps towards a vertex pushes it from the side it was on.
After the solve, vertices still inside (d < 0) are projected onto the contact plane of the nearest body vertex at the
end (or of the tracked one, where both say "inside" for a vertex that started outside: swept), repeated up to
`projection_rounds` times (concave regions).
"""
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from ..physics import energies as en
from pleat.body.model import BodyCollider

try:
    from . import blocksparse as _bs
    from . import kernels as _kn
except ImportError:                        # numba missing: the numpy path only
    _bs = _kn = None


@dataclass
class SolverSettings:
    dt_s: float = 1.0 / 30.0
    collision_margin_m: float = 4e-3      # ε: penalty starts below this distance to the body
    collision_stiffness: float = 1e6      # κ in κ·max(ε−d,0)³, J/m³
    friction: float = 0.3                 # μ_f
    friction_eps_m: float = 1e-3          # ε_u: Huber smoothing of the tangential slip per step
    force_tol: float = 1e-2               # converged: ‖∇E‖∞ ≤ force_tol · max_i(m_i g)
    max_newton: int = 80                  # Newton iterations per substep
    max_step_growth: float = 64.0         # line search: a full step that lowers E is tried ×2, ×4, … up to this
    max_body_step_m: float = 0.015        # body motion relative to the garment per substep (sets K)
    min_substeps: int = 1
    max_substeps: int = 8
    cg_max_iterations: int = 200          # truncated Newton: a CG solve stops here (the direction is still descent)
    projection_rounds: int = 5
    penetration_tol_m: float = 1e-3       # stated tolerance: no free vertex deeper than this after a step
    backend: str = "numba"                # "numba": compiled assembly (pleat.sim.kernels); "numpy": the reference
    linear_solver: str = "ic0"            # numba backend: "ic0" (incomplete-Cholesky CG) or "jacobi" (block-Jacobi CG)
    ic0_refactor_every: int = 1           # IC(0): refactor every n-th Newton iteration (reuse the factor in between)
    velocity_tol_m_s: float = 1e-2        # also converged when the Newton step ‖Δx‖∞/h ≤ this (IPC's criterion; 0: off)


@dataclass
class StepStats:
    newton_iterations: int = 0            # summed over the substeps
    cg_iterations: int = 0
    substeps: int = 1
    gradient_norm: float = 0.0            # ‖∇E‖∞ over free DOFs at the end of the last substep, N
    worst_gradient_ratio: float = 0.0     # max over substeps of final ‖∇E‖∞ / tolerance
    energies: list = field(default_factory=list)   # total energy after each accepted Newton iteration (last substep)
    penetration_before_projection_m: float = 0.0   # deepest free vertex after a solve, before projecting (all substeps)
    penetration_after_projection_m: float = 0.0    # after the projection at the frame's end
    converged: bool = True                # every substep converged
    substeps_converged: int = 0           # how many of the substeps converged (either criterion)
    substeps_force_converged: int = 0     # how many ended with ‖∇E‖∞ ≤ force tolerance
    velocity: np.ndarray = None           # [N,3] m/s at the end of the step (the next step's x_prev = x − v dt)
    trace: list = field(default_factory=list)      # per substep: [(‖∇E‖∞, ‖Δx‖∞/h of the step taken, α, CG its)]


class _Pattern:
    """Fixed CSR sparsity over the free DOFs, a scatter map from element-block entries to CSR slots, and the CSR
    slots of each free vertex's 3×3 diagonal block (for the block-Jacobi preconditioner)."""

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
        self.keep_all = bool(self.keep.all())
        self.n = int(free_dof_index.max()) + 1
        key = rows[self.keep].astype(np.int64) * self.n + cols[self.keep]
        uniq, self.inverse = np.unique(key, return_inverse=True)
        self.indices = (uniq % self.n).astype(np.int32)
        self.indptr = np.concatenate([[0], np.cumsum(np.bincount(uniq // self.n, minlength=self.n))]).astype(np.int32)
        self.nnz = len(uniq)
        base = np.arange(0, self.n, 3)
        r = base[:, None, None] + np.arange(3)[None, :, None]
        c = base[:, None, None] + np.arange(3)[None, None, :]
        self.diag_slots = np.searchsorted(uniq, r * self.n + c)          # [n/3, 3, 3]

    def matrix(self, values):
        v = values if self.keep_all else values[self.keep]
        data = np.bincount(self.inverse, weights=v, minlength=self.nnz)
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))


def _pcg(H, block_inv, b, rtol, max_iter):
    """Conjugate gradients on H x = b with a 3×3 block-Jacobi preconditioner; returns (x, iterations)."""
    n3 = len(block_inv)

    def precond(r):
        return np.matmul(block_inv, r.reshape(n3, 3, 1)).ravel()

    x = np.zeros_like(b)
    r = b.copy()
    z = precond(r)
    p = z.copy()
    rz = r @ z
    stop = rtol * np.sqrt(b @ b)
    for it in range(1, max_iter + 1):
        Hp = H @ p
        pHp = p @ Hp
        if pHp <= 0.0:
            break
        alpha = rz / pHp
        x += alpha * p
        r -= alpha * Hp
        if np.sqrt(r @ r) <= stop:
            return x, it
        z = precond(r)
        rz_new = r @ z
        p = z + (rz_new / rz) * p
        rz = rz_new
    return x, max_iter


def _bandwidth_order(faces, pinned):
    """The free vertices in reverse Cuthill–McKee order of the mesh graph. Why: IC(0)'s quality depends on the
    order; on the 4.4k t-shirt's Newton systems RCM needs ~35 % fewer preconditioned CG iterations than the
    generator's vertex order (44 against 68 to a relative residual of 10⁻³)."""
    from scipy.sparse.csgraph import reverse_cuthill_mckee
    free = np.where(~pinned)[0]
    f = np.asarray(faces, np.int64)
    rows = np.repeat(f, 3, axis=1).ravel()
    cols = np.tile(f, (1, 3)).ravel()
    graph = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(pinned), len(pinned)))[free][:, free]
    return free[reverse_cuthill_mckee(graph.tocsr(), symmetric_mode=True)]


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
        self.backend = self.settings.backend if _kn is not None else "numpy"
        if self.backend not in ("numba", "numpy"):
            raise ValueError(f"backend must be 'numba' or 'numpy', got {self.backend!r}")
        self._faces = np.ascontiguousarray(rest.faces, np.int64)
        self._hinges = np.ascontiguousarray(rest.hinges, np.int64).reshape(-1, 4)
        self._dof_order = np.where(free_dof)[0]          # the Newton system's unknowns: these DOFs, in this order
        if self.backend == "numba":           # the Newton system in 3×3 blocks, one block row per free vertex
            order = _bandwidth_order(rest.faces, self.pinned)
            free_vertex = np.full(n, -1, np.int64)
            free_vertex[order] = np.arange(len(order))
            self._dof_order = (3 * order[:, None] + np.arange(3)).ravel()
            self.blocks = _bs.BlockPattern(free_vertex, [self._faces, self._hinges, verts])
            self._face_blocks, self._hinge_blocks, vert_blocks = self.blocks.element_blocks
            self._vert_blocks = np.ascontiguousarray(vert_blocks.reshape(n))
            self._hessian_buffer = np.empty((self.blocks.n_blocks, 3, 3))
            self._ic_buffers = (np.empty((len(self.blocks.lower), 3, 3)), np.empty((self.blocks.n_block_rows, 3, 3)))
        self.stvk_mode = 0                    # kernels: 0 clamped stress (PSD), 1 |stress|, 2 exact (indefinite)
        self._ic_shift = 1e-3                 # diagonal shift (relative) that the last factorisation needed
        self._ic_factor = None                # (L blocks, inverse diagonal factors) of the last factorisation
        self._ic_streak = 0                   # factorisations in a row that succeeded at _ic_shift
        self._ic_age = 0                      # Newton iterations since it was made
        self.weight_scale = float(self.mass.max() * en.GRAVITY_M_S2)
        self._normal_force = None             # friction's λ carried from one solve to the next substep's
        self._normal_force_cache = None       # (x at the end of the last step, λ there) for the next step

    @cached_property
    def pattern(self):
        """The scalar CSR pattern over the free DOFs: the numpy backend's matrix. Built on first use, because the
        numba backend assembles into `blocks` instead (0.5 s of start-up at 4.4k for nothing)."""
        return _Pattern(self.n, self.free_dof_index, [self.rest.faces, self.rest.hinges, np.arange(self.n)[:, None]])

    # -- energy of a substep ---------------------------------------------------------------------------------------
    def _nb_contact(self, c):
        n = self.n
        if c["p"] is None:
            z = np.zeros((n, 3))
            return False, z, z, z, np.zeros(n)
        return True, c["p"], c["n"], c["body_disp"], np.asarray(c["lam"], np.float64)

    def _terms(self, x, c):
        m = self.material
        s = self.settings
        if self.backend == "numba":
            has, p, nrm, disp, lam = self._nb_contact(c)
            r = self.rest
            return float(_kn.total_energy(x, c["x_pred"], c["x_t"], self.mass, c["h"], self._faces, r.dm_inv,
                                          r.face_area, float(m.mu), float(m.lam), self._hinges, r.hinge_angle,
                                          r.hinge_weight, float(m.bending), has, p, nrm, s.collision_margin_m,
                                          s.collision_stiffness, disp, lam, s.friction, s.friction_eps_m))
        # gravity relative to the substep's start: the same minimiser, less round-off in energy differences
        e = (en.inertia_energy(x, c["x_pred"], self.mass, c["h"])
             + en.GRAVITY_M_S2 * float(self.mass @ (x[:, 1] - c["x_t"][:, 1]))
             + en.stretching_energy(x, self.rest, m.mu, m.lam) + en.bending_energy(x, self.rest, m.bending, wrap=True))
        if c["p"] is not None:
            e += en.collision_energy(x, c["p"], c["n"], s.collision_margin_m, s.collision_stiffness)
            e += en.friction_energy(x, c["x_t"], c["body_disp"], c["n"], c["lam"], s.friction, s.friction_eps_m)
        return float(e)

    def _grad_hess_data(self, x, c, hessian=True, out=None):
        """numba path: gradient [N,3] and the Hessian's 3×3 blocks [blocks, 3, 3] (`self.blocks`; into `out` if
        given), or None."""
        m = self.material
        s = self.settings
        has, p, nrm, disp, lam = self._nb_contact(c)
        r = self.rest
        g = np.empty((self.n, 3))
        data = out if hessian and out is not None else np.empty((self.blocks.n_blocks if hessian else 0, 3, 3))
        _kn.assemble(x, c["x_pred"], self.mass, c["h"], self._faces, r.dm_inv, r.face_area, float(m.mu),
                     float(m.lam), self._hinges, r.hinge_angle, r.hinge_weight, float(m.bending), has, p, nrm,
                     s.collision_margin_m, s.collision_stiffness, c["x_t"], disp, lam, s.friction, s.friction_eps_m,
                     self._face_blocks, self._hinge_blocks, self._vert_blocks, self.stvk_mode, g, data, hessian)
        return g, (data if hessian else None)

    def _grad_hess(self, x, c, hessian=True):
        m = self.material
        s = self.settings
        if self.backend == "numba":
            g, data = self._grad_hess_data(x, c, hessian)
            if not hessian:
                return g
            # the blocks are in the bandwidth order; the matrix returned is in the free DOFs' natural order
            H = self.blocks.to_scipy(data).tocoo()
            natural = self.free_dof_index[self._dof_order]
            n = len(natural)
            return g, sp.csr_matrix((H.data, (natural[H.row], natural[H.col])), shape=(n, n))
        inv_h2 = 1.0 / (c["h"] * c["h"])
        g = (self.mass * inv_h2)[:, None] * (x - c["x_pred"])
        g[:, 1] += self.mass * en.GRAVITY_M_S2
        diag = (self.mass * inv_h2)[:, None, None] * np.eye(3)
        gs, hs = en.stretching_grad_hess_gn(x, self.rest, m.mu, m.lam)
        gb, hb = en.bending_grad_hess(x, self.rest, m.bending, wrap=True)
        g += gs + gb
        if c["p"] is not None:
            gc, hc = en.collision_grad_hess(x, c["p"], c["n"], s.collision_margin_m, s.collision_stiffness)
            gf, hf = en.friction_grad_hess(x, c["x_t"], c["body_disp"], c["n"], c["lam"], s.friction,
                                           s.friction_eps_m)
            g += gc + gf
            diag = diag + hc + hf
        if not hessian:
            return g
        values = np.concatenate([hs.ravel(), hb.ravel(), diag.ravel()])
        return g, self.pattern.matrix(values)

    def _linear_solve(self, data, b, rtol):
        """Newton direction: CG preconditioned by block IC(0) (diagonal shifted until the factorisation succeeds) or
        by 3×3 block Jacobi, on the block Hessian `data`. Returns (dx, CG iterations)."""
        s = self.settings
        bp = self.blocks
        none3, none1 = np.empty((0, 3, 3)), np.empty(0, np.int64)
        if s.linear_solver == "ic0":
            factor = None
            if self._ic_factor is not None and self._ic_age < s.ic0_refactor_every:
                self._ic_age += 1
                factor = self._ic_factor
            else:
                L, Ldinv = self._ic_buffers
                self._ic_factor = None
                # the last shift that worked; after 4 successes in a row try half of it (each failed try costs a
                # factorisation, and a halving tried every time failed about every other time on the 4.4k walk)
                shift = max(1e-4, 0.5 * self._ic_shift) if self._ic_streak >= 4 else self._ic_shift
                while shift < 1.0:
                    if _bs.ic0_factor(data, bp.diagonal, bp.lower, bp.lower_ptr, bp.lower_col, shift, L, Ldinv):
                        self._ic_streak = self._ic_streak + 1 if shift == self._ic_shift else 0
                        self._ic_shift = shift
                        self._ic_factor = factor = (L, Ldinv)
                        self._ic_age = 1
                        break
                    self._ic_streak = 0
                    shift *= 2.0
            if factor is not None:
                dx, it, _ = _bs.pcg(bp.indptr, bp.indices, data, b, rtol, s.cg_max_iterations, none3, bp.lower_ptr,
                                    bp.lower_col, factor[0], factor[1], True)
                return dx, it
        Minv = _bs.block_jacobi(data, bp.diagonal)
        dx, it, _ = _bs.pcg(bp.indptr, bp.indices, data, b, rtol, s.cg_max_iterations, Minv, none1, none1, none3,
                            none3, False)
        return dx, it

    def _gradient_norm(self, x, c):
        gf = self._grad_hess(x, c, hessian=False).ravel()[self.free_dof]
        return float(np.abs(gf).max()) if gf.size else 0.0

    # -- contacts ----------------------------------------------------------------------------------------------------
    def _start_contacts(self, x0, body0, normal_force=None):
        """Nearest body vertex at the substep's start and the lagged normal force λ for friction: the penalty force
        3κ·gap² the previous solve ended with (`normal_force`), else 3κ·gap² at x0. Not from x0 after a projection:
        a vertex projected onto the surface (d = 0) sits ε deep in the margin, where the penalty force is
        3κε² = 48 N, some 10⁵ times a vertex's weight, and friction would glue it to the body for a substep."""
        s = self.settings
        idx0, _, _, d0 = body0.query(x0)
        if normal_force is None:
            gap = np.maximum(s.collision_margin_m - d0, 0.0)
            normal_force = 3.0 * s.collision_stiffness * gap * gap
        lam = np.where(self.pinned, 0.0, normal_force)
        return dict(idx0=idx0, d0=d0, lam=lam)

    def _solved_normal_force(self, x, c):
        s = self.settings
        gap = np.maximum(s.collision_margin_m - np.einsum("ij,ij->i", x - c["p"], c["n"]), 0.0)
        return 3.0 * s.collision_stiffness * gap * gap

    def _contacts(self, x, start, body0, body1, requery=False):
        """Contact point/normal per vertex on the body at the substep's end.

        requery=False (the Newton solve): the body vertex nearest to the vertex at the substep's start, moved with
        the body to the substep's end, so the energy is fixed during the solve and a limb that sweeps past a vertex
        pushes it from the side it came from. requery=True (the projection): the nearest body vertex at the end,
        except where the vertex started outside and both that and the tracked point say inside (swept)."""
        idx = start["idx0"]
        if requery:
            near, _, _, d_near = body1.query(x)
            d_tracked = body1.distance_to(x, idx)
            swept = (d_near < 0.0) & (d_tracked < 0.0) & (start["d0"] >= 0.0)
            idx = np.where(swept, idx, near)
        n = np.where(self.pinned[:, None], 0.0, body1.normals[idx])    # pinned vertices feel no contact
        p = body1.vertices[idx]
        return dict(p=p, n=n, lam=start["lam"], body_disp=p - body0.vertices[idx], idx=idx)

    # -- substep count ------------------------------------------------------------------------------------------------
    def substeps_for(self, x_t, velocity, body_t, body_next):
        s = self.settings
        if body_t is None or body_next is None or body_t is body_next:
            return max(1, s.min_substeps)
        idx, _, _, d = body_t.query(x_t)
        near = (d < 0.05) & ~self.pinned                  # garment within 5 cm of the body
        if not near.any():
            return max(1, s.min_substeps)
        rel = (body_next.vertices[idx[near]] - body_t.vertices[idx[near]]) - s.dt_s * velocity[near]
        k = int(np.ceil(np.linalg.norm(rel, axis=1).max() / s.max_body_step_m))
        return int(np.clip(k, max(1, s.min_substeps), s.max_substeps))

    # -- one frame step ------------------------------------------------------------------------------------------------
    def step(self, x_t, x_prev, pin_targets=None, body_t=None, body_next=None, pins_t=None):
        """x_{t+1} from x_t and x_{t−1} = x_t − v dt (v the velocity at t); body_t/body_next: BodyCollider at t and
        t+1 (or None for no body); pin_targets/pins_t: positions of the pinned vertices at t+1 and t."""
        s = self.settings
        x_t = np.asarray(x_t, np.float64)
        v = (x_t - np.asarray(x_prev, np.float64)) / s.dt_s
        if body_t is None:
            body_t = body_next
        pins_next = None if pin_targets is None else np.asarray(pin_targets, np.float64)
        pins_start = x_t if pins_t is None else np.asarray(pins_t, np.float64)
        K = self.substeps_for(x_t, v, body_t, body_next)
        # the friction normal force the previous step's last solve ended with, if x_t is where that step ended
        cache = self._normal_force_cache
        self._normal_force = cache[1] if cache is not None and np.array_equal(cache[0], x_t) else None
        h = s.dt_s / K
        stats = StepStats(substeps=K)
        x = x_t
        body0 = body_t
        for k in range(1, K + 1):
            frac = k / K
            if body_next is None:
                body1 = None
            elif k == K or body_t is body_next:
                body1 = body_next
            else:
                body1 = BodyCollider.lerp(body_t, body_next, frac)
            pins = None if pins_next is None else (1.0 - frac) * pins_start + frac * pins_next
            x_new = self._substep(x, v, h, pins, body0, body1, stats)
            v = (x_new - x) / h
            x = x_new
            body0 = body1
        stats.velocity = v
        self._normal_force_cache = None
        if body_next is not None:
            # last guard at the frame's end, by the plain nearest-vertex measure the tolerance is stated in
            free = ~self.pinned
            for _ in range(s.projection_rounds):
                _, _, n, d = body_next.query(x)
                inside = (d < 0.0) & free
                if not inside.any():
                    break
                x[inside] -= d[inside, None] * n[inside]
            d = body_next.query(x)[3]
            stats.penetration_after_projection_m = float(max(0.0, -d[free].min())) if free.any() else 0.0
            if self._normal_force is not None:
                self._normal_force_cache = (x.copy(), self._normal_force)
        return x, stats

    def _substep(self, x0, v0, h, pins, body0, body1, stats):
        s = self.settings
        x_pred = x0 + h * v0
        x = x_pred.copy()
        if pins is not None:
            x[self.pinned] = pins[self.pinned]
        c = dict(x_pred=x_pred, x_t=x0, h=h, p=None)
        start = None
        if body1 is not None:
            start = self._start_contacts(x0, body0, self._normal_force)
            c.update(self._contacts(x, start, body0, body1))
            # warm start: the inertial prediction, with vertices the body moved into lifted onto its surface
            d = np.einsum("ij,ij->i", x - c["p"], c["n"])
            inside = (d < 0.0) & ~self.pinned
            x[inside] -= d[inside, None] * c["n"][inside]
        x = self._newton(x, c, start, body0, body1, stats)
        self._normal_force = None
        if body1 is not None:
            self._normal_force = self._solved_normal_force(x, c)
            for k in range(s.projection_rounds):
                c.update(self._contacts(x, start, body0, body1, requery=True))
                d = np.einsum("ij,ij->i", x - c["p"], c["n"])
                inside = (d < 0.0) & ~self.pinned
                if k == 0 and inside.any():
                    stats.penetration_before_projection_m = max(stats.penetration_before_projection_m,
                                                                float(-d[inside].min()))
                if not inside.any():
                    break
                x[inside] -= d[inside, None] * c["n"][inside]
        return x

    def _newton(self, x, c, start, body0, body1, stats):
        s = self.settings
        tol = s.force_tol * self.weight_scale
        energy = self._terms(x, c)
        stats.energies = []
        tr = []
        stats.trace.append(tr)
        converged = False
        gnorm = np.inf
        for _ in range(s.max_newton):
            if self.backend == "numba":       # the Hessian's blocks into one reused buffer (no fresh pages per step)
                g, H = self._grad_hess_data(x, c, out=self._hessian_buffer)
            else:
                g, H = self._grad_hess(x, c)
            gf = g.ravel()[self._dof_order]
            gnorm = float(np.abs(gf).max()) if gf.size else 0.0
            if gnorm <= tol:
                converged = True
                break
            # forcing: CG to 10 % far from the solution, tightening as √(‖∇E‖∞ / 1000 tol), so the last Newton
            # iterations are (nearly) exact and converge quadratically (the old η = √(‖g‖/‖g₀‖) ≥ 0.1 for most
            # iterations made Newton linear with a rate of about η)
            eta = min(0.1, 0.1 * np.sqrt(gnorm / (1e3 * tol)))
            if self.backend == "numba":
                dx, cg_it = self._linear_solve(H, -gf, eta)
            else:
                blocks = H.data[self.pattern.diag_slots]
                dx, cg_it = _pcg(H, np.linalg.inv(blocks), -gf, eta, s.cg_max_iterations)
            stats.cg_iterations += cg_it
            full = np.zeros(3 * self.n)
            full[self._dof_order] = dx
            full = full.reshape(-1, 3)
            if (s.velocity_tol_m_s > 0.0 and cg_it < s.cg_max_iterations
                    and float(np.abs(dx).max()) <= s.velocity_tol_m_s * c["h"]):
                converged = True          # Newton's own estimate of the distance to the solution (CG not truncated)
                break
            slope = float(gf @ dx)
            if slope >= 0.0:                                 # not a descent direction (CG broke down): gradient step
                full = -g * self.free_dof.reshape(-1, 3) / np.maximum(np.abs(g).max(), 1e-30) * 1e-4
                slope = float(g.ravel() @ full.ravel())
            alpha = 1.0
            while True:
                trial = x + alpha * full
                e_trial = self._terms(trial, c)
                if e_trial <= energy + 1e-4 * alpha * slope:
                    break
                alpha *= 0.5
                if alpha < 1e-10:
                    break
            if alpha < 1e-10:
                # no decrease the energy can resolve: near the solution the decrease (~‖g‖²/k) falls below the
                # round-off of E itself; take the full step if it lowers the residual force, else stop
                trial = x + full
                g_trial = self._grad_hess(trial, c, hessian=False).ravel()[self._dof_order]
                if float(np.abs(g_trial).max()) >= gnorm:
                    break
                e_trial = self._terms(trial, c)
            elif alpha == 1.0:
                # along a buckling direction the clamped (PSD) Hessian overestimates the curvature and the Newton
                # step is too short; keep doubling while the energy keeps falling
                while alpha < s.max_step_growth:
                    trial2 = x + 2.0 * alpha * full
                    e2 = self._terms(trial2, c)
                    if not e2 < e_trial:
                        break
                    alpha, trial, e_trial = 2.0 * alpha, trial2, e2
            tr.append((gnorm, float(np.abs(trial - x).max()) / c["h"], alpha, int(cg_it)))
            x, energy = trial, e_trial
            stats.newton_iterations += 1
            stats.energies.append(energy)
        if not converged:
            gnorm = self._gradient_norm(x, c)
            converged = gnorm <= tol
        stats.substeps_force_converged += int(gnorm <= tol)
        stats.gradient_norm = gnorm
        stats.worst_gradient_ratio = max(stats.worst_gradient_ratio, gnorm / tol)
        stats.converged = stats.converged and converged
        stats.substeps_converged += int(converged)
        return x
