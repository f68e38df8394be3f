"""The scene's lead-in: the simulation starts from the garment's unstrained rest state, not from LBS onto frame 0."""
import numpy as np
import pytest

from pleat.physics import cloth_rest
from pleat.physics import energies as en

MOTION = "humanoid3d_walk"


def _scene():
    try:
        from pleat.motion import load_clip
        from pleat.sim.scene import load_body
        body = load_body()
        return body, load_clip(MOTION, body=body)
    except Exception:
        return None


SCENE = _scene()


def _singular_values(x, rest):
    f0, f1 = en._deformation_columns(x, rest)
    return np.linalg.svd(np.stack([f0, f1], axis=2), compute_uv=False)


@pytest.mark.skipif(SCENE is None, reason=f"body or motion clip {MOTION} not available")
def test_lead_in_starts_at_the_rest_pose_where_the_garment_is_unstrained_and_ends_at_frame_0():
    from pleat.garment import make_garment
    from pleat.sim.scene import lead_in_clip, skinning_matrices
    body, clip = SCENE
    garment = make_garment("tshirt", body=body, vertices=500)
    rest = cloth_rest(garment.shaped(None), garment.faces)
    lead = lead_in_clip(clip, frames=10, hold=3)
    assert lead.num_frames == 14
    np.testing.assert_allclose(lead.local_rotations[-1], clip.local_rotations[0], atol=1e-12)
    np.testing.assert_allclose(lead.root_translation, np.repeat(clip.root_translation[:1], 14, axis=0))
    pins = garment.skin(skinning_matrices(body, lead), None)
    first = _singular_values(pins[0], rest)
    # the template is the garment's rest shape, fitted at the body's rest pose: LBS there leaves it unstrained
    # (the pelvis rotation of frame 0 is kept: a rigid turn)
    assert np.abs(first - 1.0).max() < 1e-4                   # float32 skinning data: ~1e-5
    # whereas LBS straight onto the clip's first pose crushes and overstretches parts of it by tens of percent,
    # which is what the lead-in lets the simulation avoid
    onto_frame_0 = _singular_values(pins[-1], rest)
    assert onto_frame_0.min() < 0.8 or onto_frame_0.max() > 1.2
    # the held frames do not move
    np.testing.assert_allclose(pins[-1], pins[-2], atol=1e-12)
