"""The simulator's cheaper StVK Hessian (Gauss-Newton + clamped stress): exact in tension, PSD in compression."""
import numpy as np

from pleat.garment.sheet import grid_sheet
from pleat.physics import cloth_rest
from pleat.physics import energies as en


def _sheet():
    v, f = grid_sheet(5, 5, 0.2, 0.2, height_m=1.0)
    return v, cloth_rest(v, f)


def test_gn_hessian_equals_the_exact_hessian_in_tension():
    v, rest = _sheet()
    x = v * 1.05 + 1e-4 * np.random.default_rng(0).standard_normal(v.shape)   # stretched: stress PSD
    g_exact, h_exact = en.stretching_grad_hess(x, rest, 2e4, 4e4, project=False)
    g, h = en.stretching_grad_hess_gn(x, rest, 2e4, 4e4)
    np.testing.assert_allclose(g, g_exact, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(h, h_exact, rtol=1e-9, atol=1e-9 * np.abs(h_exact).max())


def test_gn_hessian_is_psd_in_compression_and_its_gradient_matches_finite_differences():
    v, rest = _sheet()
    rng = np.random.default_rng(1)
    x = v * 0.9 + 2e-3 * rng.standard_normal(v.shape)                      # compressed and crumpled
    g, h = en.stretching_grad_hess_gn(x, rest, 2e4, 4e4)
    assert np.linalg.eigvalsh(h).min() > -1e-9 * np.abs(h).max()
    _, h_exact = en.stretching_grad_hess(x, rest, 2e4, 4e4, project=False)
    assert np.linalg.eigvalsh(h_exact).min() < 0.0                          # the exact one is not PSD here
    eps = 1e-7
    for i, k in [(0, 0), (7, 1), (12, 2)]:
        xp, xm = x.copy(), x.copy()
        xp[i, k] += eps
        xm[i, k] -= eps
        fd = (en.stretching_energy(xp, rest, 2e4, 4e4) - en.stretching_energy(xm, rest, 2e4, 4e4)) / (2 * eps)
        assert abs(fd - g[i, k]) <= 1e-5 * max(1.0, abs(g[i, k]))
