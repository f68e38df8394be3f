"""bench/teacher_drift.py: a garment moved up its rest frame by a known amount, skinned onto a moving body, reads
back as exactly that rise, whatever the pose."""
import numpy as np


def test_a_garment_raised_in_its_rest_frame_reads_back_its_rise(load_script):
    drift = load_script("bench/teacher_drift.py")
    from pleat.garment import make_garment
    from pleat.motion import load_clip
    from pleat.sim.scene import load_body, skinning_matrices
    body = load_body()
    g = make_garment("tshirt", vertices=300, body=body)
    clip = load_clip("deepmimic_pybullet/humanoid3d_walk", body=body).resample(30.0)
    beta = np.zeros(body.num_betas)
    beta[:2] = (1.0, -0.5)
    T = 6
    rise = np.linspace(0.0, 0.05, T)                     # 0 → 5 cm up the body, in the rest frame
    rest = g.shaped(beta)[None] + rise[:, None, None] * np.array([0.0, 1.0, 0.0])
    M = skinning_matrices(body, clip, beta, slice(0, T))
    A = np.einsum("nk,tnkab->tnab", g.skin_weights, M[:, g.skin_indices])     # skinned here, un-skinned there
    posed = np.einsum("tnab,tnb->tna", A[..., :3, :3], rest) + A[..., :3, 3]
    got = drift.rest_frame_rise(posed, g, body, clip, beta)
    np.testing.assert_allclose(got, rise, atol=1e-9)
    # the posed garment moved along the body, not along world +Y: the world heights alone would not give the rise
    world = posed[..., 1].mean(1) - g.shaped(beta)[:, 1].mean()
    assert np.abs(world - rise).max() > 1e-3
