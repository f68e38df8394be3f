"""The shipped garments (assets/tshirt.pleat, assets/dress.pleat): built from the shipped body's skeleton, honest about
being a placeholder if one is, and the dress says which body parts it does not collide with."""
import json
from pathlib import Path

import numpy as np
import pytest

from pleat.asset import read_asset
from pleat.garment_asset import EXCLUDED_INPUT_JOINTS, LBS_ONLY_MODEL

ROOT = Path(__file__).resolve().parents[2]
GARMENTS = ("tshirt", "dress")
BODY = ROOT / "assets" / "body.npz"

pytestmark = pytest.mark.skipif(not BODY.exists(), reason="assets/body.npz absent")


@pytest.fixture(scope="module", params=GARMENTS)
def asset(request):
    path = ROOT / "assets" / f"{request.param}.pleat"
    if not path.exists():
        pytest.skip(f"{path.name} absent")
    return read_asset(path.read_bytes())


def test_shipped_asset_uses_the_shipped_body_skeleton(asset):
    from pleat.body import BodyModel
    body = BodyModel.load(str(BODY))
    assert [str(n) for n in asset["joint_names"]] == [str(n) for n in body.joint_names]
    assert asset["joint_parents"][1:].tolist() == list(body.parents[1:])
    # J(β) of the asset and of the body agree for the mean and a non-trivial shape (1 mm: float32 storage is far
    # below that; a stale asset built from an older body.npz is not)
    for beta in (np.zeros(10), np.linspace(-2, 2, 10)):
        body_joints = body.J_regressor @ (body.v_template + body.shapedirs @ beta)
        asset_joints = asset["joint_template"] + np.einsum("b,bjc->jc", beta, asset["joint_shapedirs"])
        assert np.abs(asset_joints - body_joints).max() < 1e-3
    expected_inputs = [k for k, n in enumerate(body.joint_names) if n not in EXCLUDED_INPUT_JOINTS]
    assert asset["input_joints"].tolist() == expected_inputs


def test_placeholder_says_it_is_untrained_and_outputs_zero(asset):
    meta = json.loads(asset["metadata_json"])
    if meta.get("model") != LBS_ONLY_MODEL:
        pytest.skip(f"a trained asset is shipped ({meta.get('model')!r})")
    for key in ("lp.0.weight", "lp.0.bias", "dec.0.weight", "dec.0.bias", "blend_shapes", "z_min", "z_max"):
        assert not np.any(asset[key]), key
    assert asset["template"].shape[0] > 1000  # the real t-shirt, not a test mesh


def test_the_dress_leaves_out_the_forearms_and_hands(asset):
    from pleat.garment.generate import SKIRT_EXCLUDED_JOINTS
    meta = json.loads(asset["metadata_json"])
    if asset["garment_name"] != "dress":
        assert "collision_exclude" not in meta
        return
    assert sorted(meta["collision_exclude"]) == sorted(SKIRT_EXCLUDED_JOINTS)
