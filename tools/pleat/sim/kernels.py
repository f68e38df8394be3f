"""Compiled (numba) per-element kernels of the simulator: the incremental potential, its gradient and the Newton
Hessian scattered straight into the values of a fixed CSR matrix, and a preconditioned CG on that matrix.

The energies are the ones of `pleat.physics.energies` (the same formulas, term by term: stretching StVK, bending
with wrap=True, inertia, gravity relative to the substep's start, cubic penalty contact, lagged Huber friction);
tests/python/test_sim_kernels.py checks energy, gradient and Hessian against the numpy functions to round-off.
Hessian blocks: StVK Gauss-Newton + clamped stress (`stretching_grad_hess_gn`, "clamp"), or, with `stvk_mode` 1,
the stress term with |eigenvalues| ("abs"), or 2, the exact stress term ("none", indefinite); bending Gauss-Newton;
contact and friction as `collision_grad_hess` / `friction_grad_hess`.

One Newton iteration at 4.4k vertices (8.7k faces, 13k hinges) costs a few milliseconds of assembly here, against
~0.2 s for the numpy path (docs/simulator.md).
"""
import math

import numpy as np
from numba import njit

PI = math.pi


@njit(cache=True, fastmath=False)
def _wrap(d):
    if d > PI:
        return d - 2.0 * PI
    if d < -PI:
        return d + 2.0 * PI
    return d


@njit(cache=True)
def total_energy(x, x_pred, x_t, mass, h, faces, dm_inv, area, mu, lam, hinges, hinge_angle, hinge_weight, kb,
                 has_contact, p, nrm, eps, kappa, body_disp, lam_n, mu_f, eps_u):
    """The substep's incremental potential (gravity measured from x_t's heights, as ClothSolver._terms)."""
    n = x.shape[0]
    inv_h2 = 1.0 / (h * h)
    e_in = 0.0
    e_gr = 0.0
    for i in range(n):
        d0 = x[i, 0] - x_pred[i, 0]
        d1 = x[i, 1] - x_pred[i, 1]
        d2 = x[i, 2] - x_pred[i, 2]
        e_in += 0.5 * mass[i] * inv_h2 * (d0 * d0 + d1 * d1 + d2 * d2)
        e_gr += mass[i] * (x[i, 1] - x_t[i, 1])
    e = e_in + 9.81 * e_gr
    e_st = 0.0
    for f in range(faces.shape[0]):
        a = faces[f, 0]
        b = faces[f, 1]
        c = faces[f, 2]
        f0x = (x[b, 0] - x[a, 0]) * dm_inv[f, 0, 0] + (x[c, 0] - x[a, 0]) * dm_inv[f, 1, 0]
        f0y = (x[b, 1] - x[a, 1]) * dm_inv[f, 0, 0] + (x[c, 1] - x[a, 1]) * dm_inv[f, 1, 0]
        f0z = (x[b, 2] - x[a, 2]) * dm_inv[f, 0, 0] + (x[c, 2] - x[a, 2]) * dm_inv[f, 1, 0]
        f1x = (x[b, 0] - x[a, 0]) * dm_inv[f, 0, 1] + (x[c, 0] - x[a, 0]) * dm_inv[f, 1, 1]
        f1y = (x[b, 1] - x[a, 1]) * dm_inv[f, 0, 1] + (x[c, 1] - x[a, 1]) * dm_inv[f, 1, 1]
        f1z = (x[b, 2] - x[a, 2]) * dm_inv[f, 0, 1] + (x[c, 2] - x[a, 2]) * dm_inv[f, 1, 1]
        e00 = 0.5 * (f0x * f0x + f0y * f0y + f0z * f0z - 1.0)
        e11 = 0.5 * (f1x * f1x + f1y * f1y + f1z * f1z - 1.0)
        e01 = 0.5 * (f0x * f1x + f0y * f1y + f0z * f1z)
        tr = e00 + e11
        e_st += area[f] * (mu * (e00 * e00 + e11 * e11 + 2.0 * e01 * e01) + 0.5 * lam * tr * tr)
    e += e_st
    e_b = 0.0
    for k in range(hinges.shape[0]):
        th = _theta(x, hinges[k, 0], hinges[k, 1], hinges[k, 2], hinges[k, 3])
        dth = _wrap(th - hinge_angle[k])
        e_b += 0.5 * kb * hinge_weight[k] * dth * dth
    e += e_b
    if has_contact:
        e_c = 0.0
        e_f = 0.0
        for i in range(n):
            d = ((x[i, 0] - p[i, 0]) * nrm[i, 0] + (x[i, 1] - p[i, 1]) * nrm[i, 1]
                 + (x[i, 2] - p[i, 2]) * nrm[i, 2])
            gap = eps - d
            if gap > 0.0:
                e_c += kappa * gap * gap * gap
            if lam_n[i] != 0.0:
                u0 = x[i, 0] - x_t[i, 0] - body_disp[i, 0]
                u1 = x[i, 1] - x_t[i, 1] - body_disp[i, 1]
                u2 = x[i, 2] - x_t[i, 2] - body_disp[i, 2]
                un = u0 * nrm[i, 0] + u1 * nrm[i, 1] + u2 * nrm[i, 2]
                t0 = u0 - un * nrm[i, 0]
                t1 = u1 - un * nrm[i, 1]
                t2 = u2 - un * nrm[i, 2]
                y = math.sqrt(max(t0 * t0 + t1 * t1 + t2 * t2, 1e-30))
                if y < eps_u:
                    hub = 0.5 * y * y / eps_u
                else:
                    hub = y - 0.5 * eps_u
                e_f += mu_f * lam_n[i] * hub
        e += e_c + e_f
    return e


@njit(cache=True)
def _theta(x, ia, ib, ic, id_):
    ex = x[ib, 0] - x[ia, 0]
    ey = x[ib, 1] - x[ia, 1]
    ez = x[ib, 2] - x[ia, 2]
    cx = x[ic, 0] - x[ia, 0]
    cy = x[ic, 1] - x[ia, 1]
    cz = x[ic, 2] - x[ia, 2]
    dx = x[id_, 0] - x[ia, 0]
    dy = x[id_, 1] - x[ia, 1]
    dz = x[id_, 2] - x[ia, 2]
    n1x = ey * cz - ez * cy                 # n1 = e × (xc − xa)
    n1y = ez * cx - ex * cz
    n1z = ex * cy - ey * cx
    n2x = dy * ez - dz * ey                 # n2 = (xd − xa) × e
    n2y = dz * ex - dx * ez
    n2z = dx * ey - dy * ex
    mx = n1y * n2z - n1z * n2y
    my = n1z * n2x - n1x * n2z
    mz = n1x * n2y - n1y * n2x
    elen = math.sqrt(ex * ex + ey * ey + ez * ez)
    return math.atan2((mx * ex + my * ey + mz * ez) / elen, n1x * n2x + n1y * n2y + n1z * n2z)


@njit(cache=True)
def assemble(x, x_pred, mass, h, faces, dm_inv, area, mu, lam, hinges, hinge_angle, hinge_weight, kb,
             has_contact, p, nrm, eps, kappa, x_t, body_disp, lam_n, mu_f, eps_u,
             face_slots, hinge_slots, vert_slots, stvk_mode, grad, data, want_hessian):
    """Gradient [N,3] into `grad` and the Newton Hessian's CSR values into `data` (zeroed here); slot arrays map
    element-block entries to CSR positions (−1: a pinned DOF, dropped)."""
    n = x.shape[0]
    inv_h2 = 1.0 / (h * h)
    for i in range(n):
        for a in range(3):
            grad[i, a] = mass[i] * inv_h2 * (x[i, a] - x_pred[i, a])
        grad[i, 1] += mass[i] * 9.81
    if want_hessian:
        data[:] = 0.0
        for i in range(n):
            w = mass[i] * inv_h2
            for a in range(3):
                s = vert_slots[i, a, a]
                if s >= 0:
                    data[s] += w
    # ---- stretching (StVK), Gauss-Newton + stress term
    B = np.empty((3, 2))
    J = np.empty((3, 9))
    CJ = np.empty((3, 9))
    Hf = np.empty((9, 9))
    K = np.empty((3, 3))
    f0 = np.empty(3)
    f1 = np.empty(3)
    for f in range(faces.shape[0]):
        ia = faces[f, 0]
        ib = faces[f, 1]
        ic = faces[f, 2]
        A = area[f]
        B[1, 0] = dm_inv[f, 0, 0]
        B[1, 1] = dm_inv[f, 0, 1]
        B[2, 0] = dm_inv[f, 1, 0]
        B[2, 1] = dm_inv[f, 1, 1]
        B[0, 0] = -(B[1, 0] + B[2, 0])
        B[0, 1] = -(B[1, 1] + B[2, 1])
        for c in range(3):
            d1 = x[ib, c] - x[ia, c]
            d2 = x[ic, c] - x[ia, c]
            f0[c] = d1 * dm_inv[f, 0, 0] + d2 * dm_inv[f, 1, 0]
            f1[c] = d1 * dm_inv[f, 0, 1] + d2 * dm_inv[f, 1, 1]
        e00 = 0.5 * (f0[0] * f0[0] + f0[1] * f0[1] + f0[2] * f0[2] - 1.0)
        e11 = 0.5 * (f1[0] * f1[0] + f1[1] * f1[1] + f1[2] * f1[2] - 1.0)
        e01 = 0.5 * (f0[0] * f1[0] + f0[1] * f1[1] + f0[2] * f1[2])
        tr = e00 + e11
        s00 = 2.0 * mu * e00 + lam * tr
        s11 = 2.0 * mu * e11 + lam * tr
        s01 = 2.0 * mu * e01
        for vi in range(3):
            vv = faces[f, vi]
            for c in range(3):
                p0 = f0[c] * s00 + f1[c] * s01
                p1 = f0[c] * s01 + f1[c] * s11
                grad[vv, c] += A * (B[vi, 0] * p0 + B[vi, 1] * p1)
        if not want_hessian:
            continue
        for vi in range(3):
            for c in range(3):
                J[0, 3 * vi + c] = B[vi, 0] * f0[c]
                J[1, 3 * vi + c] = B[vi, 1] * f1[c]
                J[2, 3 * vi + c] = 0.5 * (B[vi, 0] * f1[c] + B[vi, 1] * f0[c])
        c00 = A * (2.0 * mu + lam)
        c01 = A * lam
        c22 = A * 4.0 * mu
        for q in range(9):
            CJ[0, q] = c00 * J[0, q] + c01 * J[1, q]
            CJ[1, q] = c01 * J[0, q] + c00 * J[1, q]
            CJ[2, q] = c22 * J[2, q]
        for r in range(9):
            for q in range(9):
                Hf[r, q] = J[0, r] * CJ[0, q] + J[1, r] * CJ[1, q] + J[2, r] * CJ[2, q]
        mean = 0.5 * (s00 + s11)
        rad = math.sqrt(0.25 * (s00 - s11) ** 2 + s01 * s01)
        if rad > 0.0:
            c2 = 0.5 * (s00 - s11) / rad
            s2 = s01 / rad
        else:
            c2 = 1.0
            s2 = 0.0
        hi = mean + rad
        lo = mean - rad
        if stvk_mode == 0:
            hi = max(hi, 0.0)
            lo = max(lo, 0.0)
        elif stvk_mode == 1:
            hi = abs(hi)
            lo = abs(lo)
        q00 = lo + (hi - lo) * 0.5 * (1.0 + c2)
        q11 = lo + (hi - lo) * 0.5 * (1.0 - c2)
        q01 = (hi - lo) * 0.5 * s2
        for vi in range(3):
            for vj in range(3):
                K[vi, vj] = A * (B[vi, 0] * (q00 * B[vj, 0] + q01 * B[vj, 1])
                                 + B[vi, 1] * (q01 * B[vj, 0] + q11 * B[vj, 1]))
        for vi in range(3):
            for vj in range(3):
                for c in range(3):
                    Hf[3 * vi + c, 3 * vj + c] += K[vi, vj]
        for r in range(9):
            for q in range(9):
                s = face_slots[f, r, q]
                if s >= 0:
                    data[s] += Hf[r, q]
    # ---- bending (dihedral angle, wrap), Gauss-Newton
    Jb = np.empty(12)
    e = np.empty(3)
    ec = np.empty(3)
    ed = np.empty(3)
    n1 = np.empty(3)
    n2 = np.empty(3)
    for k in range(hinges.shape[0]):
        ia = hinges[k, 0]
        ib = hinges[k, 1]
        ic = hinges[k, 2]
        id_ = hinges[k, 3]
        for c in range(3):
            e[c] = x[ib, c] - x[ia, c]
            ec[c] = x[ic, c] - x[ia, c]
            ed[c] = x[id_, c] - x[ia, c]
        e2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2]
        elen = math.sqrt(e2)
        n1[0] = e[1] * ec[2] - e[2] * ec[1]
        n1[1] = e[2] * ec[0] - e[0] * ec[2]
        n1[2] = e[0] * ec[1] - e[1] * ec[0]
        n2[0] = ed[1] * e[2] - ed[2] * e[1]
        n2[1] = ed[2] * e[0] - ed[0] * e[2]
        n2[2] = ed[0] * e[1] - ed[1] * e[0]
        nn1 = n1[0] * n1[0] + n1[1] * n1[1] + n1[2] * n1[2]
        nn2 = n2[0] * n2[0] + n2[1] * n2[1] + n2[2] * n2[2]
        tc = (ec[0] * e[0] + ec[1] * e[1] + ec[2] * e[2]) / e2
        td = (ed[0] * e[0] + ed[1] * e[1] + ed[2] * e[2]) / e2
        for c in range(3):
            gc = -n1[c] * elen / nn1
            gd = -n2[c] * elen / nn2
            Jb[6 + c] = gc
            Jb[9 + c] = gd
            Jb[c] = -(1.0 - tc) * gc - (1.0 - td) * gd
            Jb[3 + c] = -tc * gc - td * gd
        mx = n1[1] * n2[2] - n1[2] * n2[1]
        my = n1[2] * n2[0] - n1[0] * n2[2]
        mz = n1[0] * n2[1] - n1[1] * n2[0]
        th = math.atan2((mx * e[0] + my * e[1] + mz * e[2]) / elen,
                        n1[0] * n2[0] + n1[1] * n2[1] + n1[2] * n2[2])
        cw = kb * hinge_weight[k]
        dth = _wrap(th - hinge_angle[k])
        for vi in range(4):
            vv = hinges[k, vi]
            for c in range(3):
                grad[vv, c] += cw * dth * Jb[3 * vi + c]
        if not want_hessian:
            continue
        for r in range(12):
            cr = cw * Jb[r]
            for q in range(12):
                s = hinge_slots[k, r, q]
                if s >= 0:
                    data[s] += cr * Jb[q]
    # ---- contact and friction (per vertex, diagonal blocks)
    if has_contact:
        ut = np.empty(3)
        for i in range(n):
            d = ((x[i, 0] - p[i, 0]) * nrm[i, 0] + (x[i, 1] - p[i, 1]) * nrm[i, 1]
                 + (x[i, 2] - p[i, 2]) * nrm[i, 2])
            gap = eps - d
            if gap > 0.0:
                for a in range(3):
                    grad[i, a] += -3.0 * kappa * gap * gap * nrm[i, a]
                if want_hessian:
                    for a in range(3):
                        for b in range(3):
                            s = vert_slots[i, a, b]
                            if s >= 0:
                                data[s] += 6.0 * kappa * gap * nrm[i, a] * nrm[i, b]
            cf = mu_f * lam_n[i]
            if cf == 0.0:
                continue
            u0 = x[i, 0] - x_t[i, 0] - body_disp[i, 0]
            u1 = x[i, 1] - x_t[i, 1] - body_disp[i, 1]
            u2 = x[i, 2] - x_t[i, 2] - body_disp[i, 2]
            un = u0 * nrm[i, 0] + u1 * nrm[i, 1] + u2 * nrm[i, 2]
            ut[0] = u0 - un * nrm[i, 0]
            ut[1] = u1 - un * nrm[i, 1]
            ut[2] = u2 - un * nrm[i, 2]
            y = math.sqrt(max(ut[0] * ut[0] + ut[1] * ut[1] + ut[2] * ut[2], 1e-30))
            inside = y < eps_u
            scale = 1.0 / eps_u if inside else 1.0 / y
            for a in range(3):
                grad[i, a] += cf * scale * ut[a]
            if want_hessian:
                for a in range(3):
                    for b in range(3):
                        t = (1.0 if a == b else 0.0) - nrm[i, a] * nrm[i, b]
                        if not inside:
                            t -= ut[a] * ut[b] / (y * y)
                        s = vert_slots[i, a, b]
                        if s >= 0:
                            data[s] += cf * scale * t


@njit(cache=True)
def csr_matvec(indptr, indices, data, v, out):
    for r in range(len(indptr) - 1):
        acc = 0.0
        for j in range(indptr[r], indptr[r + 1]):
            acc += data[j] * v[indices[j]]
        out[r] = acc


@njit(cache=True)
def _dot(a, b):
    acc = 0.0
    for i in range(a.shape[0]):
        acc += a[i] * b[i]
    return acc


@njit(cache=True)
def _inv3(data, slots, out):
    a = data[slots[0, 0]]
    b = data[slots[0, 1]]
    c = data[slots[0, 2]]
    d = data[slots[1, 0]]
    e = data[slots[1, 1]]
    f = data[slots[1, 2]]
    g = data[slots[2, 0]]
    h = data[slots[2, 1]]
    k = data[slots[2, 2]]
    A = e * k - f * h
    Bc = -(d * k - f * g)
    C = d * h - e * g
    det = a * A + b * Bc + c * C
    inv = 1.0 / det
    out[0, 0] = A * inv
    out[0, 1] = -(b * k - c * h) * inv
    out[0, 2] = (b * f - c * e) * inv
    out[1, 0] = Bc * inv
    out[1, 1] = (a * k - c * g) * inv
    out[1, 2] = -(a * f - c * d) * inv
    out[2, 0] = C * inv
    out[2, 1] = -(a * h - b * g) * inv
    out[2, 2] = (a * e - b * d) * inv


@njit(cache=True)
def pcg(indptr, indices, data, diag_slots, b, rtol, max_iter):
    """CG on H x = b, 3×3 block-Jacobi preconditioner (blocks read from `data` at `diag_slots` [n/3,3,3]).
    Returns (x, iterations, negative_curvature_met)."""
    nb = b.shape[0] // 3
    Minv = np.empty((nb, 3, 3))
    for i in range(nb):
        _inv3(data, diag_slots[i], Minv[i])
    no_int, no_float = np.empty(0, indptr.dtype), np.empty(0)
    return _pcg(indptr, indices, data, b, rtol, max_iter, Minv, no_int, no_int, no_float, no_float, False)


@njit(cache=True)
def _precondition(Minv, lower_ptr, lower_idx, Lval, Ldiag, use_ic0, r, z):
    """z = M⁻¹ r: the IC(0) factor's two triangular solves, or the 3×3 block-Jacobi inverses."""
    if use_ic0:
        _ic0_apply(lower_ptr, lower_idx, Lval, Ldiag, r, z)
        return
    for i in range(Minv.shape[0]):
        for a in range(3):
            z[3 * i + a] = (Minv[i, a, 0] * r[3 * i] + Minv[i, a, 1] * r[3 * i + 1]
                            + Minv[i, a, 2] * r[3 * i + 2])


@njit(cache=True)
def _pcg(indptr, indices, data, b, rtol, max_iter, Minv, lower_ptr, lower_idx, Lval, Ldiag, use_ic0):
    """Preconditioned CG on H x = b (H in CSR), stopping at ‖r‖ ≤ rtol ‖b‖ or at the first direction of non-positive
    curvature. Returns (x, iterations, negative_curvature_met)."""
    n = b.shape[0]
    x = np.zeros(n)
    r = b.copy()
    z = np.empty(n)
    Hp = np.empty(n)
    _precondition(Minv, lower_ptr, lower_idx, Lval, Ldiag, use_ic0, r, z)
    p = z.copy()
    rz = _dot(r, z)
    stop = rtol * math.sqrt(_dot(b, b))
    for it in range(1, max_iter + 1):
        csr_matvec(indptr, indices, data, p, Hp)
        pHp = _dot(p, Hp)
        if pHp <= 0.0:
            return x, it, True
        alpha = rz / pHp
        for j in range(n):
            x[j] += alpha * p[j]
            r[j] -= alpha * Hp[j]
        if math.sqrt(_dot(r, r)) <= stop:
            return x, it, False
        _precondition(Minv, lower_ptr, lower_idx, Lval, Ldiag, use_ic0, r, z)
        rz_new = _dot(r, z)
        beta = rz_new / rz
        for j in range(n):
            p[j] = z[j] + beta * p[j]
        rz = rz_new
    return x, max_iter, False


@njit(cache=True)
def ic0_factor(indptr, indices, data, lower_ptr, lower_idx, lower_src, diag_src, shift, Lval, Ldiag):
    """Incomplete Cholesky IC(0) of the CSR matrix on its own lower pattern (row i: columns lower_idx[lower_ptr[i]:
    lower_ptr[i+1]] ascending, taken from data[lower_src]; diagonal data[diag_src]), with the diagonal scaled by
    (1 + shift). Returns False on breakdown (a non-positive pivot)."""
    n = len(lower_ptr) - 1
    w = np.zeros(n)
    for i in range(n):
        a = lower_ptr[i]
        b = lower_ptr[i + 1]
        for q in range(a, b):
            w[lower_idx[q]] = data[lower_src[q]]
        for q in range(a, b):
            k = lower_idx[q]
            s = w[k]
            for r in range(lower_ptr[k], lower_ptr[k + 1]):
                s -= w[lower_idx[r]] * Lval[r] if lower_idx[r] < k else 0.0
            s /= Ldiag[k]
            w[k] = s
            Lval[q] = s
        d = data[diag_src[i]] * (1.0 + shift)
        for q in range(a, b):
            d -= Lval[q] * Lval[q]
        for q in range(a, b):
            w[lower_idx[q]] = 0.0
        if not d > 0.0:
            return False
        Ldiag[i] = math.sqrt(d)
    return True


@njit(cache=True)
def _ic0_apply(lower_ptr, lower_idx, Lval, Ldiag, r, z):
    n = len(Ldiag)
    for i in range(n):
        s = r[i]
        for q in range(lower_ptr[i], lower_ptr[i + 1]):
            s -= Lval[q] * z[lower_idx[q]]
        z[i] = s / Ldiag[i]
    for i in range(n - 1, -1, -1):
        zi = z[i] / Ldiag[i]
        z[i] = zi
        for q in range(lower_ptr[i], lower_ptr[i + 1]):
            z[lower_idx[q]] -= Lval[q] * zi


@njit(cache=True)
def pcg_ic0(indptr, indices, data, lower_ptr, lower_idx, Lval, Ldiag, b, rtol, max_iter):
    """CG on H x = b preconditioned by the IC(0) factor (L Lᵀ ≈ H). Returns (x, iterations, negative_curvature)."""
    return _pcg(indptr, indices, data, b, rtol, max_iter, np.empty((0, 3, 3)), lower_ptr, lower_idx, Lval, Ldiag,
                True)
