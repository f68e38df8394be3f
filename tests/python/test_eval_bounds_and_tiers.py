"""The displacement bound (interval arithmetic through the decoder), the Pareto front and the tier table."""
import json

import numpy as np
import pytest

from pleat import REPO_ROOT
from pleat.eval import bounds, pareto, tiers
from pleat.reference.golden import random_weights
from pleat.reference.mlp import mlp


@pytest.mark.parametrize("activation", ["relu", "silu"])
def test_interval_contains_every_sampled_decoder_output(activation):
    w = random_weights(vertices=60, latent=8, blend=6, lp_hidden=(16,), dec_hidden=(24, 24), seed=4,
                       activation=activation)
    lo, hi = bounds.blend_weight_interval(w)
    rng = np.random.default_rng(0)
    zmin, zmax = np.asarray(w["z_min"]), np.asarray(w["z_max"])
    z = zmin + rng.uniform(0, 1, (4000, len(zmin))) * (zmax - zmin)
    z[:8] = np.where(rng.uniform(size=(8, len(zmin))) < 0.5, zmin, zmax)        # corners of the box too
    layers = bounds.decoder_layers(w)
    out = mlp(z, [a for a, _ in layers], [b for _, b in layers], activation)
    assert np.all(out >= lo - 1e-9) and np.all(out <= hi + 1e-9)
    # and the interval is not vacuous: sampled outputs reach a fair part of it
    assert np.all(hi - lo < 1e3)


def test_displacement_bound_holds_for_sampled_latents():
    w = random_weights(vertices=80, latent=6, blend=5, lp_hidden=(16,), dec_hidden=(12,), seed=2)
    bound = bounds.displacement_bound_m(w)
    layers = bounds.decoder_layers(w)
    rng = np.random.default_rng(1)
    z = w["z_min"] + rng.uniform(0, 1, (500, 6)) * (w["z_max"] - w["z_min"])
    bw = mlp(z, [a for a, _ in layers], [b for _, b in layers], "relu")
    disp = np.linalg.norm(np.einsum("sd,dnc->snc", bw, w["blend_shapes"]), axis=-1)
    assert np.all(disp <= bound[None] + 1e-12)


def test_zero_network_has_zero_bound():
    from pleat.eval.scene import lbs_only_weights
    w = lbs_only_weights(random_weights(vertices=40, latent=4, blend=4, lp_hidden=(8,), dec_hidden=(8,)))
    assert np.all(bounds.displacement_bound_m(w) == 0.0)


def test_pareto_front_keeps_only_undominated_points():
    pts = [(10, 5.0), (20, 3.0), (15, 6.0), (40, 3.0), (50, 1.0), (5, 9.0)]
    assert sorted(pareto.pareto_front(pts)) == [0, 1, 4, 5]


def test_tiers_span_ten_times_in_step_cost_and_grow_monotonically():
    macs = [t.macs() for t in tiers.SHIPPED]
    assert [t.name for t in tiers.SHIPPED] == ["xsmall", "small", "medium", "large"]
    assert macs == sorted(macs)
    assert macs[-1] / macs[0] >= 10.0


def test_a_mean_of_two_students_has_their_summed_sizes_and_twice_their_network_cost():
    medium, small = tiers.tier("medium"), tiers.tier("small")
    assert medium.mean_of == "small"
    assert (medium.latent, medium.blend) == (2 * small.latent, 2 * small.blend)
    assert medium.lp_hidden == tuple(2 * w for w in small.lp_hidden)
    assert medium.dec_hidden == tuple(2 * w for w in small.dec_hidden)
    assert medium.mlp_macs() == 2 * small.mlp_macs()
    # the large tier's members (simsup.member_tier) ship nowhere, and fit the large sizes twice over
    member, large = tiers.tier("member"), tiers.tier("large")
    assert not member.asset and member not in tiers.SHIPPED
    assert large.lp_hidden == tuple(2 * w for w in member.lp_hidden) and large.latent == 2 * member.latent


def test_a_packed_name_gives_count_times_a_tiers_sizes():
    six, small = tiers.tier("6xsmall"), tiers.tier("small")
    assert six == tiers.packed("small", 6) and six.name == "6xsmall" and six.vertices == small.vertices
    assert (six.latent, six.blend) == (6 * small.latent, 6 * small.blend)
    assert six.lp_hidden == (768, 768) and six.dec_hidden == (768,)
    for bad in ("0xsmall", "6xhuge", "xsmallx", "6x"):
        with pytest.raises(ValueError):
            tiers.tier(bad)
    assert tiers.tier("xsmall").vertices == 150     # a real tier whose name starts with x is still itself


def test_large_tier_is_the_papers_configuration_and_overrides_name_real_config_keys():
    large = tiers.tier("large")
    assert (large.latent, large.blend, large.lp_hidden, large.dec_hidden) == (128, 128, (512,) * 3, (512, 512))
    cfg = json.loads((REPO_ROOT / "configs" / "default.json").read_text())
    for key in tiers.training_overrides("small"):
        node = cfg
        for part in key.split("."):
            assert part in node, f"{key} is not a key of configs/default.json"
            node = node[part]


def test_tier_spec_reads_as_a_random_asset_with_the_tiers_sizes():
    from pleat.eval.scene import read_weights
    t = tiers.tier("xsmall")
    _, w = read_weights("tier:xsmall")
    assert len(w["z_min"]) == t.latent and len(w["blend_shapes"]) == t.blend
    assert abs(len(w["template"]) - t.vertices) <= 0.05 * t.vertices
    assert w["lp.0.weight"].shape[0] == t.lp_hidden[0] and w["dec.0.weight"].shape[0] == t.dec_hidden[0]


def test_shipped_tier_assets_have_their_tiers_sizes_and_a_trained_network():
    from pleat.eval.pareto import describe_asset
    from pleat.eval.scene import is_lbs_only, read_weights
    total = 0
    for t in tiers.SHIPPED:
        path = REPO_ROOT / t.asset
        if not path.is_file():
            pytest.skip(f"{t.asset} not in this checkout")
        _, w = read_weights(str(path))
        d = describe_asset(w)
        assert (d["latent"], d["blend"]) == (t.latent, t.blend), t.name
        assert (tuple(d["lp_hidden"]), tuple(d["dec_hidden"])) == (t.lp_hidden, t.dec_hidden), t.name
        assert abs(d["vertices"] - t.vertices) <= 0.05 * t.vertices, t.name
        if t.distilled:
            assert not is_lbs_only(w) and json.loads(w["metadata_json"])["tier"] == t.name
            total += path.stat().st_size
    assert total < 10e6


def test_pareto_command_writes_the_chart_and_quotes_its_command_line(tmp_path, c_runtime):
    """pleat-pareto end to end on one small asset, times only: the page, the chart, and the command that remakes it."""
    from pleat.asset import write_asset
    asset = tmp_path / "small.pleat"
    write_asset(asset, random_weights(vertices=120, latent=4, blend=4, lp_hidden=(8,), dec_hidden=(8,), seed=1))
    assert pareto.main(["--assets", str(asset), "--no-tiers", "--no-error", "--repeats", "1", "--out", str(tmp_path),
                        "--quiet"]) == 0
    page = (tmp_path / "pareto.md").read_text()
    assert "pleat-pareto --assets " + str(asset) in page and (tmp_path / "pareto.png").stat().st_size > 0


def test_pareto_page_lists_an_ensemble_tier_by_its_members(tmp_path):
    """A large tier packed by pleat.train.ensemble has no distillation report of its own: the page's distillation
    table gives its members' PCA energy (mean), frames and summed fit time, and says what it is."""
    member = {"tier": "medium", "vertices": 1004, "pca_energy": 0.99, "train_frames": 25228, "train_time_s": 400.0,
              "validation": {"rms_mm": 10.7, "rms_zero_mm": 18.6, "rms_projection_mm": 4.0}}
    ens = {"tier": "large", "vertices": 1004, "ensemble_of": ["medium", "medium"], "members": [member, member]}
    row = dict(name="tier large (tshirt.pleat)", kind="asset", tier="large", model="pleat simulator-supervised",
               vertices=1004, latent=128, blend=128, lp_hidden=[512, 512, 512], dec_hidden=[512, 512], step_us=75.0,
               mean_mm=13.8, p95_mm=29.9, distillation=ens)
    path = tmp_path / "pareto.md"
    pareto.write_markdown([row, dict(row, name="tier medium", tier="medium", step_us=42.0, mean_mm=13.9,
                                     distillation=member)], ["clip"], "pleat-pareto …", "lib", path, 60)
    page = path.read_text()
    assert "| large (mean of 2 medium fits) | 1004 | 99.00 % | 25228 | — | — | — | 800 |" in page
    assert "| medium | 1004 | 99.00 % | 25228 | 10.70 | 18.60 | 4.00 | 400 |" in page


def test_pareto_from_suite_reports_gives_each_garment_its_baselines_and_error_bars(tmp_path, c_runtime):
    """pleat-pareto --suite: a panel per garment; per mesh one LBS-only twin (errors from the report's own runs) and,
    where the report has the reference's spread, the simulator at its CPU time per frame; mean ± SD over the runs."""
    from pleat.asset import write_asset
    assets = {}
    for name, garment, n in (("big", "skirt_a", 120), ("cheap", "skirt_a", 60), ("other", "skirt_b", 80)):
        assets[name] = str(tmp_path / f"{name}.pleat")
        write_asset(assets[name], random_weights(vertices=n, latent=4, blend=4, lp_hidden=(8,), dec_hidden=(8,),
                                                 seed=len(name), garment_name=garment))

    def run(pleat, lbs, spread=None, cpu_s=0.2):
        r = {"pleat": {"mean_mm": pleat}, "lbs": {"mean_mm": lbs},
             "reference": {"summary": {"cpu_seconds_per_frame": cpu_s}}}
        if spread is not None:
            r["reference_spread"] = {"mean_mm": spread}
        return r
    report = {assets["big"]: {"runs": [run(10, 20, 5, 0.2), run(14, 30, 7, 0.4)]},
              assets["cheap"]: {"runs": [run(20, 40), run(22, 44)]},           # no spread: no simulator point
              assets["other"]: {"runs": [run(3, 9, 2, 0.1)]}}
    path = tmp_path / "suite.json"
    path.write_text(json.dumps(report))
    assert pareto.main(["--suite", str(path), "--repeats", "1", "--out", str(tmp_path), "--json",
                        str(tmp_path / "rows.json"), "--machine", "a test machine", "--quiet"]) == 0
    rows = {(r["garment"], r["name"]): r for r in json.loads((tmp_path / "rows.json").read_text())}
    big = rows["skirt_a", "big"]
    assert (big["mean_mm"], big["sd_mm"], big["min_mm"], big["max_mm"], big["runs"]) == (12.0, 2.0, 10.0, 14.0, 2)
    assert rows["skirt_a", "LBS-only, N=120"]["mean_mm"] == 25.0 and rows["skirt_a", "LBS-only, N=60"]["sd_mm"] == 2.0
    sim = rows["skirt_a", "reference simulator, N=120"]
    assert sim["mean_mm"] == 6.0 and abs(sim["step_us"] - 3e5) < 1e-6
    assert ("skirt_a", "reference simulator, N=60") not in rows and ("skirt_b", "reference simulator, N=80") in rows
    assert all(r["step_us"] > 0 for r in rows.values())                  # the assets and twins were timed
    assert len(rows) == 8          # 3 assets, 3 LBS-only twins (one per mesh), 2 simulators
    page = (tmp_path / "pareto.md").read_text()
    assert "pleat-pareto --suite " + str(path) in page and "a test machine" in page
    assert "| skirt_b | other | pleat | 80 |" in page and (tmp_path / "pareto.png").stat().st_size > 0
