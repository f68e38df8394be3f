"""The C runtime's two body contacts against their numpy twins (pleat.reference.Instance) on the golden stand-in body
(asset 1.2: candidates, rings, rows 0..N-1 the vertices' own points): the full contact (PLEAT_BODY_CONTACT_ON) and the
fast one (PLEAT_BODY_CONTACT_FAST: each vertex's own point, its turned rest normal), step by step; the two modes
differ, and both keep the garment out of the stand-in body where plain skinning does not."""
import numpy as np

from pleat import asset as pa
from pleat.reference import Instance
from pleat.reference.golden import random_motion, random_weights


def test_full_and_fast_contact_match_their_numpy_twins_and_differ(c_runtime):
    runtime = c_runtime
    data = pa.write_asset(None, random_weights(vertices=300, latent=6, blend=4, lp_hidden=(16,), dec_hidden=(8,),
                                               seed=3))
    asset = pa.read_asset(data)
    rot, tr, rr, dt = random_motion(4, seed=6)
    out = {}
    with runtime.Context() as ctx:
        c_asset = ctx.load_asset(data)
        for mode in (runtime.BODY_CONTACT_OFF, runtime.BODY_CONTACT_ON, runtime.BODY_CONTACT_FAST):
            reference = Instance(asset, body_contact=mode)
            c_inst = ctx.create_instance(c_asset, body_contact=mode)
            for k in range(4):
                c_pos, _ = c_inst.step(rot[k], tr[k], rr[k], dt[k])
                pos, _ = reference.step(rot[k], tr[k], rr[k], dt[k])
                np.testing.assert_allclose(c_pos, pos, atol=2e-5, err_msg=f"mode {mode} step {k}")
            out[mode] = pos
            c_inst.close()
        c_asset.close()
    moved = lambda a, b: np.linalg.norm(a - b, axis=1) > 1e-6
    assert moved(out[runtime.BODY_CONTACT_ON], out[runtime.BODY_CONTACT_OFF]).sum() > 10
    assert moved(out[runtime.BODY_CONTACT_FAST], out[runtime.BODY_CONTACT_OFF]).sum() > 10
    assert moved(out[runtime.BODY_CONTACT_ON], out[runtime.BODY_CONTACT_FAST]).sum() > 10   # not the same contact
