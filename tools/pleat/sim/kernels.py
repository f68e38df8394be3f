"""Compiled (numba) per-element kernels of the simulator: the incremental potential, its gradient and the Newton
Hessian scattered straight into the 3×3 blocks of a fixed block-CSR matrix (`blocksparse`, which also solves it).

The energies are the ones of `pleat.physics.energies` (the same formulas, term by term: stretching StVK, bending
with wrap=True, inertia, gravity relative to the substep's start, cubic penalty contact, lagged Huber friction);
tests/python/test_sim_kernels.py checks energy, gradient and Hessian against the numpy functions to round-off.
Hessian blocks: StVK Gauss-Newton + clamped stress (`stretching_grad_hess_gn`, "clamp"), or, with `stvk_mode` 1,
the stress term with |eigenvalues| ("abs"), or 2, the exact stress term ("none", indefinite); bending Gauss-Newton;
contact and friction as `collision_grad_hess` / `friction_grad_hess`.

At 4.4k vertices (8.7k faces, 13k hinges) one gradient + Hessian assembly costs ~8 ms here, against ~60 ms for the
numpy path (docs/simulator.md).
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
             face_blocks, hinge_blocks, vert_blocks, stvk_mode, grad, data, want_hessian):
    """Gradient [N,3] into `grad` and the Newton Hessian's 3×3 blocks into `data` [blocks, 3, 3] (zeroed here);
    face_blocks [F,3,3], hinge_blocks [H,4,4] and vert_blocks [N] give the block of each element vertex pair
    (`blocksparse.BlockPattern`; −1: a pinned vertex, dropped)."""
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
            blk = vert_blocks[i]
            if blk >= 0:
                for a in range(3):
                    data[blk, a, a] += w
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
        for vi in range(3):
            for vj in range(3):
                blk = face_blocks[f, vi, vj]
                if blk >= 0:
                    for a in range(3):
                        for c in range(3):
                            data[blk, a, c] += Hf[3 * vi + a, 3 * vj + c]
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
        for vi in range(4):
            for vj in range(4):
                blk = hinge_blocks[k, vi, vj]
                if blk >= 0:
                    for a in range(3):
                        cr = cw * Jb[3 * vi + a]
                        for c in range(3):
                            data[blk, a, c] += cr * Jb[3 * vj + c]
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
                if want_hessian and vert_blocks[i] >= 0:
                    for a in range(3):
                        for b in range(3):
                            data[vert_blocks[i], a, b] += 6.0 * kappa * gap * nrm[i, a] * nrm[i, b]
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
            if want_hessian and vert_blocks[i] >= 0:
                for a in range(3):
                    for b in range(3):
                        t = (1.0 if a == b else 0.0) - nrm[i, a] * nrm[i, b]
                        if not inside:
                            t -= ut[a] * ut[b] / (y * y)
                        data[vert_blocks[i], a, b] += cf * scale * t
