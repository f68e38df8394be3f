"""The compiled (numba) assembly equals the numpy reference: energy, gradient, Hessian values, and CG solves."""
import numpy as np
import pytest

pytest.importorskip("numba")

from pleat.garment.sheet import grid_sheet
from pleat.physics import Material, cloth_rest
from pleat.physics import energies as en
from pleat.sim import ClothSolver, SolverSettings


def _state(seed=0, pinned=None):
    v, f = grid_sheet(6, 5, 0.2, 0.15, height_m=1.0)
    rng = np.random.default_rng(seed)
    # crumpled and compressed (clamped stress active), a few hinges folded past π from rest (wrap active)
    x = v * 0.93 + 4e-3 * rng.standard_normal(v.shape)
    n = len(v)
    nrm = rng.standard_normal((n, 3))
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    c = dict(x_pred=x + 1e-3 * rng.standard_normal((n, 3)), x_t=x + 1e-3 * rng.standard_normal((n, 3)), h=1 / 90,
             p=x + 3e-3 * rng.standard_normal((n, 3)), n=nrm, lam=np.abs(rng.standard_normal(n)) * (rng.random(n) < 0.7),
             body_disp=2e-3 * rng.standard_normal((n, 3)))
    rest = cloth_rest(v, f)
    rest.hinge_angle[:3] = 3.0                                      # sharp rest folds: θ − θ̄ wraps
    solvers = {b: ClothSolver(rest, Material(), pinned=pinned, settings=SolverSettings(backend=b))
               for b in ("numpy", "numba")}
    return x, c, solvers


@pytest.mark.parametrize("pinned", [None, [0, 5]])
@pytest.mark.parametrize("contact", [True, False])
def test_numba_assembly_equals_numpy(pinned, contact):
    x, c, solvers = _state(pinned=pinned)
    if not contact:
        c["p"] = None
    e = {b: s._terms(x, c) for b, s in solvers.items()}
    assert e["numba"] == pytest.approx(e["numpy"], rel=1e-12)
    g0, H0 = solvers["numpy"]._grad_hess(x, c)
    g1, H1 = solvers["numba"]._grad_hess(x, c)
    np.testing.assert_allclose(g1, g0, rtol=0, atol=1e-12 * np.abs(g0).max())
    np.testing.assert_allclose(H1.toarray(), H0.toarray(), rtol=0, atol=1e-12 * np.abs(H0.data).max())
    assert np.abs(H0.toarray() - H0.toarray().T).max() <= 1e-12 * np.abs(H0.data).max()


def test_numba_stress_modes_match_the_numpy_variants():
    x, c, solvers = _state(seed=3)
    c["p"] = None
    s = solvers["numba"]
    m = s.material
    for mode, name in ((0, "clamp"), (1, "abs"), (2, "none")):
        s.stvk_mode = mode
        _, H = s._grad_hess(x, c)
        # the numba Hessian minus everything but stretching, against stretching_grad_hess_gn's blocks
        _, hs = en.stretching_grad_hess_gn(x, s.rest, m.mu, m.lam, stress_projection=name)
        _, hb = en.bending_grad_hess(x, s.rest, m.bending, wrap=True)
        diag = (s.mass / c["h"] ** 2)[:, None, None] * np.eye(3)
        ref = s.pattern.matrix(np.concatenate([hs.ravel(), hb.ravel(), diag.ravel()]))
        np.testing.assert_allclose(H.toarray(), ref.toarray(), rtol=0, atol=1e-12 * np.abs(ref.data).max())


def test_numba_solver_steps_like_the_numpy_solver():
    """A few steps of a sheet pinned along one edge: with the same linear solver (block-Jacobi CG) both backends take
    the same Newton path and end at the same positions; IC(0)-preconditioned CG converges every step too (it may end
    in a slightly different state: the swinging sheet buckles, the minimiser is not unique)."""
    v, f = grid_sheet(6, 6, 0.3, 0.3, height_m=1.0)
    pins = np.where(np.isclose(v[:, 2], v[:, 2].min()))[0]
    out = {}
    for b, lin in (("numpy", "jacobi"), ("numba", "jacobi"), ("numba-ic0", "ic0")):
        solver = ClothSolver(cloth_rest(v, f), Material(), pinned=pins,
                             settings=SolverSettings(dt_s=1 / 30, backend=b.split("-")[0], linear_solver=lin,
                                                     velocity_tol_m_s=0.0))
        x, x_prev = v.copy(), v.copy()
        for _ in range(5):
            x_new, stats = solver.step(x, x_prev, pin_targets=v)
            assert stats.converged
            x_prev, x = x, x_new
        out[b] = x
    # converged to ‖∇E‖∞ ≤ 1e-2 m g each: vertices agree to far below a millimetre
    assert np.abs(out["numba"] - out["numpy"]).max() < 1e-5
