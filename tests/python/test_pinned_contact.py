"""Pinned vertices (the pants' waistband) follow the body by skinning in the simulator and are never moved by its
contact; the runtime's body contact leaves them alone too (no contact candidates), in both contact modes, through
pleat-garment-asset and through pleat-pack --body-contact. The other vertices keep theirs."""
import numpy as np
import pytest

from pleat import asset as pa
from pleat.body import BodyModel
from pleat.garment import make_garment
from pleat.garment_asset import weights_from_garment


@pytest.fixture(scope="module")
def body():
    return BodyModel.load()


@pytest.fixture(scope="module")
def pants_weights(body):
    return weights_from_garment(make_garment("pants", vertices=600, body=body), body)


def test_pinned_vertices_get_no_contact_candidates(pants_weights):
    pinned = np.asarray(pants_weights["pinned"])
    table = pants_weights["body_anchor_candidates"]
    assert len(pinned) > 10
    assert np.all(table[pinned] == pa.NO_CANDIDATE)
    free = np.setdiff1d(np.arange(len(table)), pinned)
    assert np.mean(table[free, 0] != pa.NO_CANDIDATE) > 0.95           # the rest of the pants keep their contact
    # the fast contact reads each vertex's own row: a pinned vertex's has no normal, so it never anchors
    assert np.all(np.linalg.norm(pants_weights["body_anchor_normal"][pinned], axis=1) == 0.0)


def test_repacking_keeps_pinned_vertices_out_of_the_contact(tmp_path, pants_weights):
    from pleat import pack
    src = tmp_path / "in.pleat"
    stale = dict(pants_weights)
    stale.pop("body_anchor_candidates")                                  # an older block, redone by the pack
    pa.write_asset(src, {k: v for k, v in stale.items() if not k.startswith("body_anchor")})
    out = tmp_path / "out.pleat"
    assert pack.main([str(src), "-o", str(out), "--body-contact"]) == 0
    table = pa.read_asset(out.read_bytes())["body_anchor_candidates"]
    assert np.all(table[np.asarray(pants_weights["pinned"])] == pa.NO_CANDIDATE)


def test_the_runtime_contact_leaves_pinned_vertices_where_skinning_puts_them(c_runtime, body, pants_weights):
    from pleat.eval import scene as S
    data = pa.write_asset(None, pants_weights)
    clip = S.load_motion("deepmimic_pybullet/humanoid3d_run", body, S.EVAL_FPS, 20)
    rot = S.clip_rotations_for(clip, pants_weights["joint_names"])
    pinned = np.asarray(pants_weights["pinned"])
    with c_runtime.Context() as ctx:
        asset = ctx.load_asset(data)
        runs = {}
        for mode in (c_runtime.BODY_CONTACT_OFF, c_runtime.BODY_CONTACT_ON, c_runtime.BODY_CONTACT_FAST):
            inst = ctx.create_instance(asset, body_contact=mode, body_contact_offset_m=0.02)
            runs[mode] = np.stack([inst.step(rot[t], clip.root_translation[t], clip.root_rotation[t],
                                             1.0 / clip.fps)[0] for t in range(clip.num_frames)])
            inst.close()
        asset.close()
    off = runs[c_runtime.BODY_CONTACT_OFF]
    for mode in (c_runtime.BODY_CONTACT_ON, c_runtime.BODY_CONTACT_FAST):
        np.testing.assert_array_equal(runs[mode][:, pinned], off[:, pinned])
        assert np.abs(runs[mode] - off).max() > 1e-3                    # a 2 cm clearance moves the other vertices
