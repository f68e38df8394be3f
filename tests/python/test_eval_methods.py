"""pleat-methods' rows: one row per asset from pleat-eval-suite reports, LBS-only and the reference from the same
runs, and --rows (adding assets to an earlier chart)."""
import json

import numpy as np
import pytest

from pleat.eval import methods


def _suite(asset, errors, step_us, lbs_errors, spread=3.0, ref_s=0.2):
    runs = [{"pleat": {"mean_mm": e, "step_us": step_us}, "lbs": {"mean_mm": l, "step_us": 15.0},
             "reference": {"summary": {"cpu_seconds_per_frame": ref_s}}, "reference_spread": {"mean_mm": spread}}
            for e, l in zip(errors, lbs_errors)]
    return {asset: {"runs": runs}}


def test_rows_from_suites_give_each_asset_lbs_and_the_reference(tmp_path):
    p = tmp_path / "a.json"
    p.write_text(json.dumps(_suite("a.pleat", [10.0, 14.0], 80.0, [20.0, 26.0])))
    rows = methods.rows_from_suites([str(p)], {"a.pleat": "model A"})
    by_kind = {r["kind"]: r for r in rows}
    assert by_kind["asset"]["name"] == "model A"
    assert by_kind["asset"]["mean_mm"] == pytest.approx(12.0)
    assert (by_kind["asset"]["lo"], by_kind["asset"]["hi"], by_kind["asset"]["us"]) == (10.0, 14.0, 80.0)
    assert by_kind["lbs"]["mean_mm"] == pytest.approx(23.0)
    assert by_kind["reference"]["us"] == pytest.approx(2e5)
    assert by_kind["reference"]["mean_mm"] == pytest.approx(3.0)


def test_rows_add_assets_to_an_earlier_chart_and_keep_its_baselines():
    earlier = [dict(name="old", kind="asset", asset="old.pleat", us=70.0, mean_mm=13.0, lo=5.0, hi=27.0, runs=14),
               dict(name="again", kind="asset", asset="b.pleat", us=60.0, mean_mm=19.0, lo=9.0, hi=30.0, runs=14),
               dict(name="LBS-only", kind="lbs", us=15.0, mean_mm=23.5, lo=13.0, hi=37.0, runs=14),
               dict(name="reference", kind="reference", us=1.6e5, mean_mm=9.2, lo=0.7, hi=40.0, runs=126)]
    new = [dict(name="new", kind="asset", asset="new.pleat", us=110.0, mean_mm=20.3, lo=9.0, hi=35.0, runs=14),
           dict(name="b again", kind="asset", asset="b.pleat", us=61.0, mean_mm=18.0, lo=9.0, hi=29.0, runs=14),
           dict(name="LBS-only", kind="lbs", us=16.0, mean_mm=23.6, lo=13.0, hi=37.0, runs=14)]
    rows = methods.merge_rows(earlier, new)
    assert [r["name"] for r in rows] == ["old", "new", "b again", "LBS-only", "reference"]
    assert rows[3]["us"] == 15.0          # the earlier chart's LBS-only, not the new suite's
    assert np.isfinite([r["mean_mm"] for r in rows]).all()
