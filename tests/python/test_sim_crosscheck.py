"""The cross-check's pleat-side math: the hinge energy against plate theory, and the bending conversion to newton."""
import numpy as np

from pleat.garment.sheet import grid_sheet
from pleat.physics import Material, cloth_rest, dihedral_angles
from pleat.sim.crosscheck import (bending_ke, cantilever_theory, cylinder_bend, hinge_bending_stiffness,
                                  make_cantilever)

K = Material().bending


def test_cylinder_bend_turns_only_the_edges_across_the_bend_by_kappa_times_the_spacing():
    v, faces = grid_sheet(7, 5, 0.06, 0.04)                 # spacing 0.01 m both ways
    rest = cloth_rest(v, faces)
    theta = dihedral_angles(cylinder_bend(v, 5.0, 0), rest)
    h = rest.hinges
    across = np.isclose(v[h[:, 0], 0], v[h[:, 1], 0])       # hinge edge parallel to z: the bend is along x
    np.testing.assert_allclose(np.abs(theta[across]), 5.0 * 0.01, rtol=1e-12)
    np.testing.assert_allclose(theta[~across], 0.0, atol=1e-12)


def test_hinge_energy_is_a_plate_of_stiffness_3k_along_the_grid_axes_and_stiffer_across_the_diagonal():
    # analytic: a cylinder along x turns each edge parallel to z by κh, weight 3h²/h² = 3, one such edge per h² cell:
    # E/A = ½ · 3k · κ²
    assert np.isclose(hinge_bending_stiffness(K, along=0), 3.0 * K, rtol=1e-9)
    assert np.isclose(hinge_bending_stiffness(K, along=2), 3.0 * K, rtol=1e-9)
    diagonal = hinge_bending_stiffness(K, along=np.array([1.0, 0.0, 1.0]) / np.sqrt(2.0))
    assert 4.4 * K < diagonal < 4.6 * K                      # measured 4.4998 k: the grid's hinge energy is anisotropic


def test_newton_edge_stiffness_times_length_is_pleats_hinge_weight_times_k():
    v, faces, _ = make_cantilever()
    rest = cloth_rest(v, faces)
    # newton's edge rows are (opposite 0, opposite 1, edge start, edge end); plus one boundary edge (opposite 1 = −1)
    edges = np.concatenate([rest.hinges[:, [2, 3, 0, 1]], [[faces[0, 2], -1, faces[0, 0], faces[0, 1]]]])
    length = np.linalg.norm(v[edges[:, 3]] - v[edges[:, 2]], axis=1)
    ke = bending_ke(v, faces, edges, length, K)
    np.testing.assert_allclose(ke[:-1] * length[:-1], K * rest.hinge_weight, rtol=1e-12)
    assert ke[-1] == 0.0


def test_cantilever_theory_chain_and_elastica_approach_euler_bernoulli_for_a_small_load():
    q, d, length = 1.964, 3.0 * K * 1000.0, 0.09             # tip drop ~0.15 % of the length
    t = cantilever_theory(q, d, length, segments=400)
    assert np.isclose(t["elastica_tip_drop_m"], t["euler_bernoulli_tip_drop_m"], rtol=1e-4)
    assert np.isclose(t["chain_tip_drop_m"], t["euler_bernoulli_tip_drop_m"], rtol=1e-2)
    large = cantilever_theory(q, 3.0 * K, length, segments=400)   # the cantilever scene: large deflection
    assert large["elastica_tip_drop_m"] < 0.6 * large["euler_bernoulli_tip_drop_m"]
    assert np.isclose(large["chain_tip_drop_m"], large["elastica_tip_drop_m"], rtol=1e-2)
