"""The incremental-potential terms of the paper's equation (4), after HOOD, written once for numpy and torch.

Every `*_energy` function takes positions `x` [N, 3] (numpy float64 or a torch tensor) plus rest data from
`ClothRest` (convert it once with `ClothRest.to(like)` for torch) and returns a scalar, the sum over the garment.
The `*_grad_hess` functions are numpy only: the analytic gradient [N, 3] and element Hessian blocks, projected to
positive semi-definite where the exact Hessian can be indefinite, as the Newton solver in `pleat.sim` needs them.

Units: metres, kilograms, seconds; energies in joules. Definitions (docs/simulator.md has the derivations):

    stretching  Σ_f  Ā_f · ( μ tr(E_f²) + ½ λ tr(E_f)² ),   E = ½(FᵀF − I),  F = [x1−x0, x2−x0] · Dm⁻¹   (StVK)
    bending     Σ_e  ½ k · 3‖ē‖²/(Ā₁+Ā₂) · (θ_e − θ̄_e)²       (θ: signed dihedral angle of the hinge at edge e)
    inertia     Σ_i  ½ m_i/dt² · ‖x_i − x̃_i‖²,  x̃ = 2x_t − x_{t−1} (implicit Euler's predicted position)
    gravity     Σ_i  m_i g y_i            (g = 9.81 m/s² along −Y)
    collision   Σ_i  κ · max(ε − d_i, 0)³,  d_i = (x_i − p_i)·n_i   (p, n: nearest posed-body point and its normal)
    friction    Σ_i  μ_f λ_i · φ(‖T_i u_i‖),  u_i = (x_i − x_t,i) − (p_i − p_t,i),  T_i = I − n_i n_iᵀ,
                φ = Huber: y²/(2 ε_u) below ε_u, y − ε_u/2 above; λ_i the normal force, held fixed in a step

m_i is a vertex mass: the material's areal density m (kg/m²) times a third of the rest area of the vertex's faces.
"""
from dataclasses import dataclass, fields

import numpy as np

from .xp import cross, dot, namespace

GRAVITY_M_S2 = 9.81


@dataclass
class ClothRest:
    """Rest data of a garment mesh, computed once from its template (rest 3D triangles)."""
    faces: np.ndarray          # [F, 3] int64, outward (counter-clockwise seen from outside)
    dm_inv: np.ndarray         # [F, 2, 2] inverse rest shape matrix in each face's own 2D frame
    face_area: np.ndarray      # [F] rest area, m²
    hinges: np.ndarray         # [H, 4] int64 (a, b, c, d): edge a→b, c opposite in the face with a→b, d in the other
    hinge_angle: np.ndarray    # [H] rest dihedral angle θ̄, rad
    hinge_weight: np.ndarray   # [H] 3‖ē‖²/(Ā₁+Ā₂), dimensionless
    edges: np.ndarray          # [E, 2] int64 unique edges
    edge_length: np.ndarray    # [E] rest edge lengths, m
    vertex_area: np.ndarray    # [N] a third of the rest area of the adjacent faces, m² (mass = density · this)

    def to(self, like):
        """The same rest data as arrays of `like`'s kind (dtype and device for torch)."""
        ops = namespace(like)
        return ClothRest(**{f.name: ops.asarray(getattr(self, f.name), like=like) for f in fields(self)})


def unique_edges(faces):
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]).astype(np.int64)
    e.sort(axis=1)
    return np.unique(e, axis=0)


def hinges_of(faces):
    """Interior edges as hinges (a, b, c, d); needs a consistently oriented manifold mesh."""
    f = np.asarray(faces, np.int64)
    directed = np.concatenate([f[:, [0, 1, 2]], f[:, [1, 2, 0]], f[:, [2, 0, 1]]])  # (a, b, opposite)
    key = {(int(a), int(b)): int(c) for a, b, c in directed}
    out = []
    for (a, b), c in key.items():
        if a < b and (b, a) in key:
            out.append((a, b, c, key[(b, a)]))
    return np.array(out, dtype=np.int64).reshape(-1, 4)


def _dihedral(xa, xb, xc, xd, xp):
    e = xb - xa
    n1 = cross(e, xc - xa, xp)
    n2 = cross(xd - xa, e, xp)
    elen = xp.sqrt(dot(e, e))
    s = dot(cross(n1, n2, xp), e) / elen
    return xp.atan2(s, dot(n1, n2))


def cloth_rest(template, faces):
    x = np.asarray(template, np.float64)
    f = np.asarray(faces, np.int64)
    d1 = x[f[:, 1]] - x[f[:, 0]]
    d2 = x[f[:, 2]] - x[f[:, 0]]
    l1 = np.linalg.norm(d1, axis=1)
    n = np.cross(d1, d2)
    nlen = np.linalg.norm(n, axis=1)
    if np.any(nlen <= 0) or np.any(l1 <= 0):
        raise ValueError("garment has degenerate (zero-area) faces")
    dm = np.zeros((len(f), 2, 2))
    dm[:, 0, 0] = l1
    dm[:, 0, 1] = np.einsum("ij,ij->i", d1, d2) / l1
    dm[:, 1, 1] = nlen / l1
    area = 0.5 * nlen
    hinges = hinges_of(f)
    face_of = {}
    for fi, (a, b, c) in enumerate(f):
        face_of[(a, b)] = fi
        face_of[(b, c)] = fi
        face_of[(c, a)] = fi
    if len(hinges):
        fa = np.array([face_of[(a, b)] for a, b in hinges[:, :2]])
        fb = np.array([face_of[(b, a)] for a, b in hinges[:, :2]])
        elen2 = np.sum((x[hinges[:, 1]] - x[hinges[:, 0]]) ** 2, axis=1)
        weight = 3.0 * elen2 / (area[fa] + area[fb])
        angle = _dihedral(*(x[hinges[:, i]] for i in range(4)), np)
    else:
        weight = angle = np.zeros(0)
    edges = unique_edges(f)
    vertex_area = np.zeros(len(x))
    np.add.at(vertex_area, f.ravel(), np.repeat(area / 3.0, 3))
    return ClothRest(faces=f, dm_inv=np.linalg.inv(dm), face_area=area, hinges=hinges, hinge_angle=angle,
                     hinge_weight=weight, edges=edges,
                     edge_length=np.linalg.norm(x[edges[:, 1]] - x[edges[:, 0]], axis=1), vertex_area=vertex_area)


# ---------------------------------------------------------------------------------------------------------------
# Energies (numpy or torch)

def _deformation_columns(x, rest):
    f = rest.faces
    x0 = x[f[:, 0]]
    d1 = x[f[:, 1]] - x0
    d2 = x[f[:, 2]] - x0
    di = rest.dm_inv
    f0 = d1 * di[:, 0, 0, None] + d2 * di[:, 1, 0, None]
    f1 = d1 * di[:, 0, 1, None] + d2 * di[:, 1, 1, None]
    return f0, f1


def stretching_energy(x, rest, mu, lam):
    """StVK membrane energy; mu, lam in Pa·m (2D Lamé parameters), scalars or per face."""
    f0, f1 = _deformation_columns(x, rest)
    e00 = 0.5 * (dot(f0, f0) - 1.0)
    e11 = 0.5 * (dot(f1, f1) - 1.0)
    e01 = 0.5 * dot(f0, f1)
    tr = e00 + e11
    psi = mu * (e00 * e00 + e11 * e11 + 2.0 * e01 * e01) + 0.5 * lam * tr * tr
    return namespace(x).sum(rest.face_area * psi)


def dihedral_angles(x, rest):
    h = rest.hinges
    return _dihedral(x[h[:, 0]], x[h[:, 1]], x[h[:, 2]], x[h[:, 3]], namespace(x))


def _wrap_angle(d, xp):
    """d ∈ (−2π, 2π) → the same angle in [−π, π]."""
    return xp.where(d > np.pi, d - 2.0 * np.pi, xp.where(d < -np.pi, d + 2.0 * np.pi, d))


def bending_energy(x, rest, k, wrap=False):
    """Dihedral-angle bending about the rest angles; k in J (N·m).

    wrap=True measures θ − θ̄ in [−π, π]. Without it a hinge whose rest angle is near ±π (sharp folds of a
    procedural garment's template: the t-shirt has θ̄ up to 3.03 rad) jumps by 2π when it folds a little further:
    the energy is discontinuous there (a line search cannot pass it) and the force tries to unfold it the long way
    round. The default keeps the original definition."""
    xp = namespace(x)
    dtheta = dihedral_angles(x, rest) - rest.hinge_angle
    if wrap:
        dtheta = _wrap_angle(dtheta, xp)
    return xp.sum(0.5 * k * rest.hinge_weight * dtheta * dtheta)


def inertia_energy(x, x_pred, mass, dt):
    d = x - x_pred
    return namespace(x).sum(0.5 * mass / (dt * dt) * dot(d, d))


def gravity_energy(x, mass, g=GRAVITY_M_S2):
    return namespace(x).sum(mass * g * x[:, 1])


def collision_energy(x, contact_point, contact_normal, eps, stiffness):
    """Cubic penalty on garment vertices closer than eps (m) to the body along its normal (HOOD's ε-margin)."""
    xp = namespace(x)
    gap = xp.relu(eps - dot(x - contact_point, contact_normal))
    return xp.sum(stiffness * gap * gap * gap)


def _huber(y, eps, xp):
    return xp.where(y < eps, 0.5 * y * y / eps, y - 0.5 * eps)


def friction_energy(x, x_t, body_displacement, contact_normal, normal_force, mu_f, eps_u):
    """Lagged smoothed Coulomb friction: relative tangential displacement against the body during the step."""
    xp = namespace(x)
    u = (x - x_t) - body_displacement
    ut = u - dot(u, contact_normal)[:, None] * contact_normal
    y = xp.sqrt(xp.clamp_min(dot(ut, ut), 1e-30))
    return xp.sum(mu_f * normal_force * _huber(y, eps_u, xp))


# ---------------------------------------------------------------------------------------------------------------
# Gradients and Hessian blocks (numpy, for Newton)

def _scatter_add(n, index, values):
    """Σ of `values` rows [M, 3] into [n, 3] at `index` [M] (bincount per component: ~10× np.add.at)."""
    return np.stack([np.bincount(index, weights=values[:, k], minlength=n) for k in range(3)], axis=1)


def _project_psd(h):
    w, v = np.linalg.eigh(h)
    return np.einsum("...ij,...j,...kj->...ik", v, np.maximum(w, 0.0), v)


def stretching_grad_hess(x, rest, mu, lam, project=True):
    """Gradient [N,3] and per-face Hessian blocks [F,9,9] (order x0,x1,x2 × xyz), PSD-projected in F-space."""
    f0, f1 = _deformation_columns(x, rest)
    n_f = len(rest.faces)
    mu = np.broadcast_to(np.asarray(mu, np.float64), (n_f,))
    lam = np.broadcast_to(np.asarray(lam, np.float64), (n_f,))
    F = np.stack([f0, f1], axis=2)                           # [F,3,2]
    E = 0.5 * (np.einsum("fai,faj->fij", F, F) - np.eye(2))
    tr = E[:, 0, 0] + E[:, 1, 1]
    S = 2.0 * mu[:, None, None] * E + (lam * tr)[:, None, None] * np.eye(2)
    P = np.einsum("fak,fkj->faj", F, S)                      # ∂ψ/∂F [F,3,2]
    B = np.zeros((n_f, 3, 2))                                # dF = Σ_i x_i ⊗ B_i
    B[:, 1] = rest.dm_inv[:, 0, :]
    B[:, 2] = rest.dm_inv[:, 1, :]
    B[:, 0] = -(B[:, 1] + B[:, 2])
    A = rest.face_area
    gface = A[:, None, None] * np.einsum("faj,fij->fia", P, B)   # [F,3 verts,3]
    grad = np.zeros_like(x)
    np.add.at(grad, rest.faces.ravel(), gface.reshape(-1, 3))
    # H[(a,j),(b,l)] = δ_ab S_lj + μ F_al F_bj + μ δ_lj (FFᵀ)_ab + λ F_aj F_bl
    I3 = np.eye(3)
    I2 = np.eye(2)
    FFt = np.einsum("faj,fbj->fab", F, F)
    HF = (np.einsum("ab,flj->fajbl", I3, S)
          + mu[:, None, None, None, None] * np.einsum("fal,fbj->fajbl", F, F)
          + mu[:, None, None, None, None] * np.einsum("lj,fab->fajbl", I2, FFt)
          + lam[:, None, None, None, None] * np.einsum("faj,fbl->fajbl", F, F)).reshape(n_f, 6, 6)
    if project:
        HF = _project_psd(HF)
    HF = HF.reshape(n_f, 3, 2, 3, 2)
    BH = np.einsum("fij,fajbl->fiabl", B * A[:, None, None], HF)
    H = np.einsum("fiabl,fkl->fiakb", BH, B)
    return grad, H.reshape(n_f, 9, 9)


def bending_grad_hess(x, rest, k, wrap=False):
    """Gradient [N,3] and Gauss-Newton Hessian blocks [H,12,12] (order a,b,c,d × xyz), PSD by construction.
    wrap: as in `bending_energy`."""
    h = rest.hinges
    xa, xb, xc, xd = (x[h[:, i]] for i in range(4))
    e = xb - xa
    e2 = dot(e, e)
    elen = np.sqrt(e2)
    n1 = np.cross(e, xc - xa)
    n2 = np.cross(xd - xa, e)
    gc = -n1 * (elen / dot(n1, n1))[:, None]
    gd = -n2 * (elen / dot(n2, n2))[:, None]
    tc = (dot(xc - xa, e) / e2)[:, None]
    td = (dot(xd - xa, e) / e2)[:, None]
    ga = -(1.0 - tc) * gc - (1.0 - td) * gd
    gb = -tc * gc - td * gd
    J = np.stack([ga, gb, gc, gd], axis=1).reshape(-1, 12)       # ∇θ per hinge
    theta = np.arctan2(dot(np.cross(n1, n2), e) / elen, dot(n1, n2))
    c = k * rest.hinge_weight
    dtheta = theta - rest.hinge_angle
    if wrap:
        dtheta = _wrap_angle(dtheta, np)
    gh = (c * dtheta)[:, None] * J
    grad = _scatter_add(len(x), h.ravel(), gh.reshape(-1, 3))
    cJ = c[:, None] * J
    H = cJ[:, :, None] * J[:, None, :]
    return grad, H


def collision_grad_hess(x, contact_point, contact_normal, eps, stiffness):
    """Gradient [N,3] and per-vertex Hessian blocks [N,3,3]."""
    gap = np.maximum(eps - dot(x - contact_point, contact_normal), 0.0)
    grad = (-3.0 * stiffness * gap * gap)[:, None] * contact_normal
    H = (6.0 * stiffness * gap)[:, None, None] * np.einsum("ni,nj->nij", contact_normal, contact_normal)
    return grad, H


def friction_grad_hess(x, x_t, body_displacement, contact_normal, normal_force, mu_f, eps_u):
    """Gradient [N,3] and per-vertex Hessian blocks [N,3,3] (PSD: the Huber's concave part is dropped)."""
    n = contact_normal
    u = (x - x_t) - body_displacement
    ut = u - dot(u, n)[:, None] * n
    y = np.sqrt(np.maximum(dot(ut, ut), 1e-30))
    c = mu_f * normal_force
    inside = y < eps_u
    scale = np.where(inside, 1.0 / eps_u, 1.0 / y)
    grad = (c * scale)[:, None] * ut
    T = np.eye(3) - np.einsum("ni,nj->nij", n, n)
    uhat = ut / y[:, None]
    slide = T - np.einsum("ni,nj->nij", uhat, uhat)        # Hessian of y in the sliding regime, times y
    H = (c * scale)[:, None, None] * np.where(inside[:, None, None], T, slide)
    return grad, H


def stretching_grad_hess_gn(x, rest, mu, lam, stress_projection="clamp"):
    """StVK gradient [N,3] (the same as `stretching_grad_hess`) and cheaper PSD Hessian blocks [F,9,9].

    The exact Hessian is Jᵀ C J + (stress term) with J = ∂E/∂x, C = ∂²ψ/∂E² (PSD for μ > 0, λ ≥ 0) and the stress
    term A (B S Bᵀ) ⊗ I₃ (S = 2μE + λ tr(E) I, the second Piola-Kirchhoff stress). Clamping the 2×2 S to its
    non-negative eigenvalues (closed form) makes the sum PSD without a 6×6 eigen-decomposition per face; in tension
    (S PSD) it is the exact Hessian.

    stress_projection="abs" uses |eigenvalues| of S instead (also PSD, also exact in tension): in compression the
    clamped stress term leaves only inertia against out-of-plane buckling, so Newton's steps there are far too long
    and zig-zag; the absolute value keeps the stress's curvature magnitude (after Chen et al. 2024, abs-eigenvalue
    projection).

    stress_projection="none" keeps S as it is: the exact StVK Hessian, indefinite in compression (for a solver that
    handles negative curvature itself).
    """
    if stress_projection not in ("clamp", "abs", "none"):
        raise ValueError(f"stress_projection must be 'clamp', 'abs' or 'none', got {stress_projection!r}")
    f0, f1 = _deformation_columns(x, rest)
    n_f = len(rest.faces)
    mu = np.broadcast_to(np.asarray(mu, np.float64), (n_f,))
    lam = np.broadcast_to(np.asarray(lam, np.float64), (n_f,))
    A = rest.face_area
    e00 = 0.5 * (dot(f0, f0) - 1.0)
    e11 = 0.5 * (dot(f1, f1) - 1.0)
    e01 = 0.5 * dot(f0, f1)
    tr = e00 + e11
    s00 = 2.0 * mu * e00 + lam * tr
    s11 = 2.0 * mu * e11 + lam * tr
    s01 = 2.0 * mu * e01
    B = np.empty((n_f, 3, 2))                                # dF = Σ_i x_i ⊗ B_i
    B[:, 1] = rest.dm_inv[:, 0, :]
    B[:, 2] = rest.dm_inv[:, 1, :]
    B[:, 0] = -(B[:, 1] + B[:, 2])
    p0 = f0 * s00[:, None] + f1 * s01[:, None]               # columns of P = F S
    p1 = f0 * s01[:, None] + f1 * s11[:, None]
    gface = A[:, None, None] * (B[:, :, 0, None] * p0[:, None, :] + B[:, :, 1, None] * p1[:, None, :])
    grad = _scatter_add(len(x), rest.faces.ravel(), gface.reshape(-1, 3))
    # J_p = ∂E_p/∂x for E_p ∈ (e00, e11, e01), each [F, 3 vertices × 3]
    j0 = B[:, :, 0, None] * f0[:, None, :]
    j1 = B[:, :, 1, None] * f1[:, None, :]
    j2 = 0.5 * (B[:, :, 0, None] * f1[:, None, :] + B[:, :, 1, None] * f0[:, None, :])
    J = np.stack([j0.reshape(n_f, 9), j1.reshape(n_f, 9), j2.reshape(n_f, 9)], axis=1)     # [F, 3, 9]
    C = np.zeros((n_f, 3, 3))                                # ∂²ψ/∂E_p∂E_q times the rest area
    C[:, 0, 0] = C[:, 1, 1] = A * (2.0 * mu + lam)
    C[:, 0, 1] = C[:, 1, 0] = A * lam
    C[:, 2, 2] = A * 4.0 * mu
    H = np.matmul(J.transpose(0, 2, 1), np.matmul(C, J))
    # S = w_hi P + w_lo (I − P), P the projector on the top eigenvector; clamp both eigenvalues at 0
    mean = 0.5 * (s00 + s11)
    rad = np.sqrt(0.25 * (s00 - s11) ** 2 + s01 * s01)
    safe = np.where(rad > 0, rad, 1.0)
    c2 = np.where(rad > 0, 0.5 * (s00 - s11) / safe, 1.0)   # cos 2φ
    s2 = np.where(rad > 0, s01 / safe, 0.0)                  # sin 2φ
    if stress_projection == "abs":
        hi, lo = np.abs(mean + rad), np.abs(mean - rad)
    elif stress_projection == "none":
        hi, lo = mean + rad, mean - rad
    else:
        hi, lo = np.maximum(mean + rad, 0.0), np.maximum(mean - rad, 0.0)
    S_psd = np.empty((n_f, 2, 2))
    S_psd[:, 0, 0] = lo + (hi - lo) * 0.5 * (1.0 + c2)
    S_psd[:, 1, 1] = lo + (hi - lo) * 0.5 * (1.0 - c2)
    S_psd[:, 0, 1] = S_psd[:, 1, 0] = (hi - lo) * 0.5 * s2
    K = A[:, None, None] * np.matmul(np.matmul(B, S_psd), B.transpose(0, 2, 1))   # [F, 3, 3] vertex × vertex
    H = H.reshape(n_f, 3, 3, 3, 3)
    for a in range(3):
        H[:, :, a, :, a] += K
    return grad, H.reshape(n_f, 9, 9)
