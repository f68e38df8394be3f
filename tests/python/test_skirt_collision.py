"""A skirt collides with the trunk and legs only (Garment.collision_exclude): the simulator's contact, the runtime's
contact candidates and the penetration measure leave the forearms and hands out, and the asset carries the choice so
that the evaluation simulates the same scene."""
import numpy as np
import pytest

from pleat.body import BodyModel
from pleat.body.model import SMPL_JOINT_NAMES, BodyCollider
from pleat.garment import Garment, make_garment
from pleat.garment.generate import SKIRT_EXCLUDED_JOINTS


@pytest.fixture(scope="module")
def body():
    return BodyModel.load()


@pytest.fixture(scope="module")
def dress(body):
    return make_garment("dress", vertices=400, body=body)


def test_only_the_dress_leaves_out_forearms_and_hands(body, dress):
    assert sorted(SMPL_JOINT_NAMES[j] for j in dress.collision_exclude) == sorted(SKIRT_EXCLUDED_JOINTS)
    assert make_garment("tank_top", vertices=300, body=body).body_collision_mask(body) is None
    mask = dress.body_collision_mask(body)
    dominant = np.argmax(body.weights, axis=1)
    assert not mask[np.isin(dominant, dress.collision_exclude)].any()
    assert mask[dominant == SMPL_JOINT_NAMES.index("left_hip")].all()


def test_collider_never_answers_with_a_left_out_vertex(body, dress):
    mask = dress.body_collision_mask(body)
    hand = body.v_template[np.argmax(body.weights, axis=1) == SMPL_JOINT_NAMES.index("left_wrist")]
    points = hand + np.random.default_rng(0).normal(0, 0.01, hand.shape)     # around the hand itself
    whole, masked = BodyCollider(body.v_template, body.faces), BodyCollider(body.v_template, body.faces, mask)
    for c in (masked, BodyCollider.lerp(masked, masked, 0.5)):
        idx, p, n, d = c.query(points)
        assert mask[idx].all()
        _, idx8, _ = c.signed_distance(points, k=8)
        assert mask[idx8].all()
    # without a mask nothing changes: the hand's own vertices answer
    idx, *_ = whole.query(points)
    assert not mask[idx].all()
    np.testing.assert_array_equal(whole.query(body.v_template[:50])[0], np.arange(50))


def test_npz_round_trip_and_older_files(tmp_path, dress):
    dress.save(tmp_path / "d.npz")
    np.testing.assert_array_equal(Garment.load(tmp_path / "d.npz").collision_exclude, dress.collision_exclude)
    with np.load(tmp_path / "d.npz") as z:
        older = {k: z[k] for k in z.files if k != "collision_exclude"}
    np.savez(tmp_path / "old.npz", **older)
    assert len(Garment.load(tmp_path / "old.npz").collision_exclude) == 0


def test_the_asset_carries_it_to_the_evaluation(body, dress):
    from pleat.eval import scene as S
    from pleat.garment_asset import weights_from_garment
    weights = weights_from_garment(dress, body)
    again = S.garment_from_asset(weights)
    np.testing.assert_array_equal(np.sort(again.collision_exclude), np.sort(dress.collision_exclude))
    np.testing.assert_array_equal(S.collision_mask(weights, body), dress.body_collision_mask(body))
    # the runtime's contact points are never on a left-out part
    mask = dress.body_collision_mask(body)
    from pleat.asset import NO_CANDIDATE
    cand = weights["body_anchor_candidates"]
    used = np.unique(cand[cand != NO_CANDIDATE])
    points = weights["body_anchor"][used]
    on_part = np.array([mask[np.argmin(np.linalg.norm(body.v_template - p, axis=1))] for p in points])
    assert len(used) > 100 and on_part.all()


def test_cache_key_changes_only_for_a_garment_that_leaves_parts_out(body, dress):
    from dataclasses import replace

    from pleat.eval.reference import cache_key
    from pleat.motion import identity_clip
    from pleat.sim import SolverSettings
    clip, settings, beta, mat = identity_clip(3), SolverSettings(), np.zeros(10), np.ones(4)
    whole = replace(dress, collision_exclude=np.zeros(0, np.int32))
    k_dress = cache_key(dress, body, beta, mat, clip, 3, settings)
    k_whole = cache_key(whole, body, beta, mat, clip, 3, settings)
    assert k_dress != k_whole
    assert k_whole == cache_key(replace(whole), body, beta, mat, clip, 3, settings)


def test_a_swinging_hand_does_not_carry_the_skirt(body, dress):
    """The walk in which the whole-body contact lifted the hem 0.3 m at the hand (the skirt hooked on it and carried
    to the hip); colliding with the trunk and legs only, the hem stays within a few cm of its own median height."""
    from pleat.garment import mesh as M
    from pleat.motion.loaders import load_clip_at
    from pleat.sim.scene import simulate
    clip = load_clip_at("humanoid3d_walk", body, 30.0)
    positions, _, summary = simulate(dress, body, clip, frames=24, progress=False, keep_body=False)
    assert np.isfinite(positions).all()
    hem = min(M.boundary_loops(dress.faces), key=lambda L: dress.template[L, 1].mean())
    y = positions[:, hem, 1]
    assert (y.max(axis=1) - np.median(y, axis=1)).max() < 0.12
