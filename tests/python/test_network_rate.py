"""plInstanceDef.network_rate_hz: the networks run at their own rate under a faster game loop (docs/inputs.md,
"Network update rate"), in the numpy reference and in the C runtime, which agree."""
import numpy as np
import pytest

from pleat import asset as pa
from pleat.reference import Instance
from pleat.reference import golden


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    out = tmp_path_factory.mktemp("rate")
    assert golden.main(["--out", str(out), "--frames", "24", "--vertices", "300", "--seed", "3"]) == 0
    case = golden.read_case(out / "case.bin")
    return out, pa.read_asset((out / "asset.pleat").read_bytes()), case


def _pose(case, k):
    return case["rotations"][k], case["root_translation"][k], case["root_rotation"][k]


def _assert_half_rate_equals_every_other_pose(at_32hz, every_step, case):
    """at_32hz stepped at 64 fps, every_step given every other pose at dt = 1/32 (binary-exact dts): after each of
    the former's network updates both hold the same latent, positions and normals, bit for bit."""
    for k in range(24):
        pos_a, nrm_a = at_32hz.step(*_pose(case, k), 1 / 64)
        if k % 2 == 0:
            pos_b, nrm_b = every_step.step(*_pose(case, k), 1 / 32)
            np.testing.assert_array_equal(at_32hz.latent, every_step.latent)
            np.testing.assert_array_equal(pos_a, pos_b)
            np.testing.assert_array_equal(nrm_a, nrm_b)


def test_half_rate_network_sees_exactly_the_half_rate_history(small):
    """At 32 Hz under a 64 fps loop the networks run on every other step with dt = 1/32: exactly what an instance
    without a rate computes when it is given every other pose at dt = 1/32."""
    _, asset, case = small
    _assert_half_rate_equals_every_other_pose(Instance(asset, case["beta"], case["material"], network_rate_hz=32.0),
                                              Instance(asset, case["beta"], case["material"]), case)


def test_between_updates_the_latent_is_held_and_the_held_deformation_follows_the_pose(small):
    _, asset, case = small
    inst = Instance(asset, case["beta"], case["material"], network_rate_hz=20.0)
    pos0, _ = inst.step(*_pose(case, 0), 1 / 60)
    z0, w0 = inst.latent.copy(), inst.blend_weights.copy()
    pos1, _ = inst.step(*_pose(case, 1), 1 / 60)                    # 1/60 < 1/20: no update
    np.testing.assert_array_equal(inst.latent, z0)
    np.testing.assert_array_equal(inst.blend_weights, w0)
    assert np.abs(pos1 - pos0).max() > 1e-3                          # the pose moved the garment
    pos2, _ = inst.step(*_pose(case, 0), 1 / 60)                    # back to the first pose: the same garment
    np.testing.assert_allclose(pos2, pos0, atol=1e-12)
    inst.step(*_pose(case, 3), 1 / 60)                              # 3/60 = 1/20: the networks run
    assert np.abs(inst.latent - z0).max() > 1e-6 and inst.network_pending_s == 0.0


def test_a_network_dt_beyond_the_assets_range_is_clamped_and_reported(small):
    _, asset, case = small
    inst = Instance(asset, case["beta"], case["material"], network_rate_hz=5.0)   # 0.2 s > dt_max 1/15
    inst.step(*_pose(case, 0), 1 / 30)
    results = []
    for k in range(1, 13):
        inst.step(*_pose(case, k), 1 / 30)
        results.append(inst.last_result)
    assert results.count("clamped") == 2 and results.count("ok") == 10    # updates at steps 6 and 12


def test_invalid_rates_are_rejected(small):
    _, asset, case = small
    for bad in (-1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError):
            Instance(asset, case["beta"], case["material"], network_rate_hz=bad)


@pytest.mark.parametrize("rate, dt", [(30.0, 1 / 60), (24.0, 1 / 90), (32.0, 1 / 64)])
def test_c_runtime_matches_the_reference_with_a_network_rate(small, rate, dt, c_runtime):
    runtime = c_runtime
    out, asset, case = small
    ref = Instance(asset, case["beta"], case["material"], network_rate_hz=rate)
    with runtime.Context() as ctx:
        c_asset = ctx.load_asset((out / "asset.pleat").read_bytes())
        inst = ctx.create_instance(c_asset, beta=case["beta"], material=case["material"], network_rate_hz=rate)
        updates = 0
        for k in range(24):
            if k == 9:                     # a new body between two network updates: the held deformation follows it
                beta = np.asarray(case["beta"]) + 0.5
                inst.set_shape(beta)
                ref.set_shape(beta)
            before = inst.latent
            pos, nrm = inst.step(*_pose(case, k), dt)
            pos_r, _ = ref.step(*_pose(case, k), dt)
            updates += int(np.any(inst.latent != before)) if k else 1
            assert inst.last_result == 0, f"step {k}"
            # tolerances of test_reference_golden.run_c (float32 C against the float64 reference)
            np.testing.assert_allclose(inst.latent, ref.latent, atol=1e-3, err_msg=f"step {k}")
            np.testing.assert_allclose(pos, pos_r, atol=1e-4, err_msg=f"step {k}")
        assert updates == pytest.approx(24 * rate * dt, abs=1.01)
        inst.close()
        c_asset.close()


def test_c_half_rate_equals_full_rate_on_every_other_pose_bit_for_bit(small, c_runtime):
    runtime = c_runtime
    out, _, case = small
    with runtime.Context() as ctx:
        c_asset = ctx.load_asset((out / "asset.pleat").read_bytes())
        a = ctx.create_instance(c_asset, beta=case["beta"], material=case["material"], network_rate_hz=32.0)
        b = ctx.create_instance(c_asset, beta=case["beta"], material=case["material"])
        _assert_half_rate_equals_every_other_pose(a, b, case)
        # a rate can change at run time, and a bad one changes nothing
        with pytest.raises(runtime.PleatError):
            a.set_network_rate(float("nan"))
        a.set_network_rate(0.0)
        z = a.latent
        a.step(*_pose(case, 0), 1 / 64)
        assert np.any(a.latent != z)
        with pytest.raises(runtime.PleatError):
            ctx.create_instance(c_asset, network_rate_hz=-1.0)
        for x in (a, b, c_asset):
            x.close()
