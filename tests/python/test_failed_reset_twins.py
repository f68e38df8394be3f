"""A step that is non-finite even from the reset state: the C runtime and its numpy twin (pleat.reference.Instance) both
dress the body without the learned deformation — zero latent, zero blend weights, the shaped template skinned with the
pose — commit that, and report NUMERIC_RESET (plInstance_Step's contract in pleat.h)."""
import numpy as np

from pleat import asset as pa
from pleat.reference.body_contact import body_contact
from pleat.reference import Instance, shape_blend, skinning
from pleat.reference.golden import random_motion, random_weights

LP_LAYERS = 8
HUGE = 3e38          # just below float32's largest


def _overflowing_weights():
    """f_LP overflows on every step, first frames included, in float32 (C) and in float64 (numpy).

    X_c[L + 8], the first 6D component of input joint 0's rotation, is ~1 for any pose (the rotation's (0, 0)
    entry); with x_std 1e-38 it normalises to ~1e38. Every LP layer then multiplies by HUGE (times the width after the
    first): float32 overflows in layer 1, float64 by layer 8."""
    w = random_weights(vertices=150, latent=8, blend=6, lp_hidden=(16,) * (LP_LAYERS - 1), dec_hidden=(8,), seed=11)
    L = len(w["z_mean"])
    w["x_mean"] = np.asarray(w["x_mean"], np.float64).copy()
    w["x_std"] = np.asarray(w["x_std"], np.float64).copy()
    w["x_mean"][L + 8], w["x_std"][L + 8] = 0.0, 1e-38
    first = np.zeros_like(np.asarray(w["lp.0.weight"], np.float64))
    first[:, L + 8] = HUGE
    w["lp.0.weight"] = first
    for i in range(1, LP_LAYERS):
        w[f"lp.{i}.weight"] = np.full(np.asarray(w[f"lp.{i}.weight"]).shape, HUGE)
    return w


def test_non_finite_from_the_reset_state_dresses_the_body_without_learned_deformation_in_both_twins(c_runtime):
    data = pa.write_asset(None, _overflowing_weights())
    asset = pa.read_asset(data)
    rot, tr, rr, dt = random_motion(3, seed=4)
    beta = np.linspace(-1.0, 1.0, np.asarray(asset["shape_blend"]).shape[0])
    reference = Instance(asset, beta)
    runtime = c_runtime
    with runtime.Context() as ctx:
        c_asset = ctx.load_asset(data)
        c_inst = ctx.create_instance(c_asset, beta=beta)
        for k in range(3):          # a first frame, then steps with a history: each one resets and falls back
            c_pos, c_nrm = c_inst.step(rot[k], tr[k], rr[k], dt[k])
            pos, nrm = reference.step(rot[k], tr[k], rr[k], dt[k])
            assert c_inst.last_result == runtime.RESULT_NUMERIC_RESET, f"step {k}"
            assert reference.last_result == "numeric_reset", f"step {k}"
            for latent, weights in ((c_inst.latent, c_inst.blend_weights),
                                    (reference.latent, reference.blend_weights)):
                assert not np.any(latent) and not np.any(weights)
            # the body without learned deformation: T + G_S(β), skinned with this pose's matrices (then kept outside
            # the body, as every step is: the asset has body contact)
            shaped = shape_blend(asset["template"], asset["shape_blend"], reference.beta)
            expected = skinning(shaped, asset["skin_indices"], asset["skin_weights"], reference.skin_matrices)
            assert reference.body_contact
            expected = body_contact(expected, reference.shaped_anchors, reference.anchor_normals,
                                    reference.anchor_skin_indices, reference.anchor_skin_weights,
                                    reference.skin_matrices, reference.body_contact_offset_m,
                                    reference.anchor_candidates, reference.anchor_ring,
                                    reach=not reference.body_contact_fast)
            np.testing.assert_allclose(pos, expected, atol=1e-12)
            np.testing.assert_allclose(c_pos, pos, atol=1e-5, err_msg=f"step {k}")
            np.testing.assert_allclose(c_nrm, nrm, atol=1e-4, err_msg=f"step {k}")
            np.testing.assert_allclose(c_inst.skin_matrices, reference.skin_matrices, atol=1e-5)
        c_inst.close()
        c_asset.close()
