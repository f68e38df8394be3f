"""The simulator's bending term with θ − θ̄ wrapped to [−π, π] (energies.bending_*(wrap=True))."""
import numpy as np

from pleat.physics import cloth_rest
from pleat.physics import energies as en

FACES = np.array([[0, 1, 2], [1, 0, 3]])          # hinge on edge 0-1, wings 2 and 3


def _hinge(phi):
    """Wing 3 turned by phi about the hinge edge (the x axis) from wing 2's direction."""
    return np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.05, 0.08, 0.0],
                     [0.05, 0.08 * np.cos(phi), 0.08 * np.sin(phi)]])


def _theta(phi, rest):
    return float(en.dihedral_angles(_hinge(phi), rest)[0])


def test_bending_with_a_rest_angle_near_pi_is_continuous_when_wrapped_and_jumps_by_2pi_when_not():
    # a template fold of ~3.0 rad (the procedural t-shirt has rest angles up to 3.03 rad)
    phis = np.linspace(0.05, 0.6, 2000)
    probe = cloth_rest(_hinge(0.3), FACES)
    thetas = np.array([_theta(p, probe) for p in phis])
    phi_rest = phis[np.argmin(np.abs(np.abs(thetas) - 3.0))]
    rest = cloth_rest(_hinge(phi_rest), FACES)
    assert abs(abs(rest.hinge_angle[0]) - 3.0) < 1e-2
    # fold it further, through θ = ±π (where atan2 wraps)
    path = np.linspace(phi_rest - 0.2, phi_rest + 0.2, 801) if _theta(phi_rest - 0.2, rest) * _theta(phi_rest + 0.2, rest) < 0 \
        else np.linspace(phi_rest + 0.2, phi_rest - 0.2, 801)
    th = np.array([_theta(p, rest) for p in path])
    assert np.any(np.abs(np.diff(th)) > np.pi)      # the path does cross the wrap
    k = 1e-3
    wrapped = np.array([en.bending_energy(_hinge(p), rest, k, wrap=True) for p in path])
    plain = np.array([en.bending_energy(_hinge(p), rest, k) for p in path])
    step = np.abs(np.diff(path)).max()
    c = k * rest.hinge_weight[0]
    # wrapped: Lipschitz along the path, |dE| ≤ c·|Δθ|·|dθ| with |Δθ| ≤ 0.3 here (and |dθ| ≈ |dφ|)
    assert np.abs(np.diff(wrapped)).max() <= 2.0 * c * 0.3 * step
    # the original definition jumps where θ wraps (energy ~ ½c(2π − 0.2)² on the far side)
    assert np.abs(np.diff(plain)).max() > 10.0 * c


def test_wrapped_bending_gradient_matches_finite_differences_past_pi():
    phis = np.linspace(0.05, 0.6, 2000)
    probe = cloth_rest(_hinge(0.3), FACES)
    thetas = np.array([_theta(p, probe) for p in phis])
    rest = cloth_rest(_hinge(phis[np.argmin(np.abs(np.abs(thetas) - 3.0))]), FACES)
    rng = np.random.default_rng(3)
    for phi in np.linspace(0.05, 0.6, 7):
        x = _hinge(phi) + rng.standard_normal((4, 3)) * 1e-4
        g, _ = en.bending_grad_hess(x, rest, 1e-3, wrap=True)
        d = rng.standard_normal((4, 3))
        eps = 1e-7
        fd = (en.bending_energy(x + eps * d, rest, 1e-3, wrap=True)
              - en.bending_energy(x - eps * d, rest, 1e-3, wrap=True)) / (2 * eps)
        assert abs(fd - float(np.sum(g * d))) <= 1e-6 * max(1e-9, abs(fd)) + 1e-10
