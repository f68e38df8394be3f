"""The simulator's block-CSR linear algebra (pleat.sim.blocksparse): product, IC(0) and CG on a cloth Hessian."""
import numpy as np
import pytest

pytest.importorskip("numba")

from pleat.garment.sheet import grid_sheet
from pleat.physics import Material, cloth_rest
from pleat.sim import ClothSolver, SolverSettings
from pleat.sim import blocksparse as bs


def _hessian(pinned=(0, 5)):
    v, f = grid_sheet(7, 6, 0.2, 0.15, height_m=1.0)
    rng = np.random.default_rng(1)
    x = v * 0.97 + 2e-3 * rng.standard_normal(v.shape)
    s = ClothSolver(cloth_rest(v, f), Material(), pinned=list(pinned), settings=SolverSettings(backend="numba"))
    c = dict(x_pred=x, x_t=x, h=1 / 60, p=None)
    g, data = s._grad_hess_data(x, c)
    return s, data, g.ravel()[s._dof_order]


def test_block_matvec_equals_scipy():
    s, data, _ = _hessian()
    bp = s.blocks
    v = np.random.default_rng(2).standard_normal(3 * bp.n_block_rows)
    out = np.empty_like(v)
    bs.bsr_matvec(bp.indptr, bp.indices, data, v, out)
    np.testing.assert_allclose(out, bp.to_scipy(data) @ v, rtol=1e-13, atol=1e-13 * np.abs(out).max())


def test_ic0_reproduces_the_matrix_on_its_pattern():
    """IC(0)'s defining property: (L Lᵀ)ᵢⱼ = Aᵢⱼ wherever A has a block (the error lives off the pattern only)."""
    s, data, _ = _hessian()
    bp = s.blocks
    L = np.empty((len(bp.lower), 3, 3))
    Ldinv = np.empty((bp.n_block_rows, 3, 3))
    # the smallest diagonal shift that factorises (a cloth Hessian is not diagonally dominant: IC(0) can break down)
    shift = next(s for s in (0.0, 1e-4, 1e-3, 1e-2, 1e-1) if bs.ic0_factor(data, bp.diagonal, bp.lower, bp.lower_ptr,
                                                                              bp.lower_col, s, L, Ldinv))
    n = 3 * bp.n_block_rows
    Lfull = np.zeros((n, n))
    rows = np.repeat(np.arange(bp.n_block_rows), np.diff(bp.lower_ptr))
    for q, (i, k) in enumerate(zip(rows, bp.lower_col)):
        Lfull[3 * i:3 * i + 3, 3 * k:3 * k + 3] = L[q]
    for i in range(bp.n_block_rows):
        Lfull[3 * i:3 * i + 3, 3 * i:3 * i + 3] = np.linalg.inv(Ldinv[i])
    assert np.allclose(np.triu(Lfull[0:3, 0:3], 1), 0.0)                 # the diagonal factors are lower-triangular
    A = bp.to_scipy(data).toarray()
    A[np.diag_indices_from(A)] *= 1.0 + shift
    on_pattern = (A != 0.0) | (bp.to_scipy(np.ones_like(data)).toarray() != 0.0)
    err = np.abs(Lfull @ Lfull.T - A)
    assert err[on_pattern].max() <= 1e-10 * np.abs(A).max()
    assert err[~on_pattern].max() > 1e-8 * np.abs(A).max()             # it is incomplete: fill is dropped


@pytest.mark.parametrize("solver", ["ic0", "jacobi"])
def test_pcg_solves_the_newton_system(solver):
    s, data, g = _hessian()
    s.settings.linear_solver = solver
    s.settings.cg_max_iterations = 500
    dx, it = s._linear_solve(data, -g, 1e-10)
    H = s.blocks.to_scipy(data)
    assert np.linalg.norm(H @ dx + g) <= 1e-9 * np.linalg.norm(g)
    assert it < 500


def test_ic0_needs_fewer_iterations_than_block_jacobi():
    s, data, g = _hessian()
    its = {}
    for solver in ("ic0", "jacobi"):
        s.settings.linear_solver = solver
        s.settings.cg_max_iterations = 1000
        s._ic_factor = None
        its[solver] = s._linear_solve(data, -g, 1e-8)[1]
    assert its["ic0"] < its["jacobi"]
