"""pleat-stability's pages: one asset keeps its sections on stability.md; several get a summary row each there and
their sections on a page of their own (stability-NAME.md), and a run that went wrong shows in its row."""
from pleat.eval import stability


def _run(**kw):
    return dict(dict(finite=True, numeric_resets=0, bound_excess_mm=-100.0, deviation_mean_mm=10.0,
                     deviation_max_mm=20.0), **kw)


def _report(asset, garment, pleat_mm, lbs_mm, fast_ok=True):
    ref = dict(frames=15, pleat_error_mm=pleat_mm, lbs_error_mm=lbs_mm, pleat_penetration_pct=0.1,
               pleat_max_depth_mm=2.0, lbs_penetration_pct=2.0, lbs_max_depth_mm=9.0, reference_penetration_pct=0.0,
               reference_max_depth_mm=0.0, reference_seconds_per_frame=0.2)
    window = dict(start_frame=0, frames=15, pleat_error_mm=pleat_mm, pleat_fresh_error_mm=pleat_mm,
                  lbs_error_mm=lbs_mm, reference_penetration_pct=0.0, reference_max_depth_mm=0.0,
                  reference_seconds_per_frame=0.2)
    return dict(
        asset=asset, garment=garment, model="network", quick=True, vertices=1000, clips=["walk"],
        displacement_bound_max_mm=1e5, reference_window_frames=15, wall_s=10.0, plots=[], plot_prefix=garment + "_",
        long=_run(frames=5000, seconds=166.7, latent_norm_max=3.0, latent_in_range=True,
                  drift=dict(window=500, first_start=8, first_window_mm=10.0, last_window_mm=10.1, ratio=1.01,
                             slope_mm_per_min=0.01),
                  penetration=dict(pleat=dict(penetration_pct=0.3, max_depth_mm=5.0),
                                   lbs=dict(penetration_pct=2.5, max_depth_mm=20.0)),
                  reference_windows=dict(first=window, last=dict(window, start_frame=4985))),
        fast={"walk 3×": _run(speed=3.0, frames=100, finite=fast_ok)},
        fast_reference={"walk 1×": dict(ref, speed=1.0), "walk 3×": dict(ref, speed=3.0, pleat_error_mm=2 * pleat_mm)},
        bodies={"beta0=+3": _run(component=0, value=3.0)},
        bodies_reference={"beta0=-3": ref, "beta0=+3": dict(ref, pleat_error_mm=3 * pleat_mm)},
        dt_jitter={"walk": _run(frames=300, dt_min_s=0.008, dt_max_s=0.066, clamped_steps=2)})


def test_one_asset_keeps_its_sections_on_the_page(tmp_path):
    page = tmp_path / "stability.md"
    stability.write_markdown([_report("assets/tshirt.pleat", "tshirt", 12.0, 20.0)], page, "pleat-stability ...")
    text = page.read_text()
    assert "## Asset `assets/tshirt.pleat`" in text and "### (a) Long run" in text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["stability.md"]


def test_several_assets_get_a_summary_row_each_and_a_page_of_their_own(tmp_path):
    page = tmp_path / "stability.md"
    reports = [_report("assets/tshirt.pleat", "tshirt", 12.0, 20.0),
               _report("assets/dress.pleat", "dress", 30.0, 50.0, fast_ok=False)]
    stability.write_markdown(reports, page, "pleat-stability --asset assets/tshirt.pleat assets/dress.pleat")
    text = page.read_text()
    assert "### (a) Long run" not in text                                  # the sections moved to their pages
    rows = [line for line in text.splitlines() if line.startswith("| [`assets/")]
    assert len(rows) == 2
    tshirt, dress = rows
    # end of the long run, 3× speed (twice the 1× error here), the worst β by its ratio to LBS-only (β0 = +3)
    assert "(stability-tshirt.md) | 1000 | 1.0100 | 12.00 / 20.00 | 24.00 / 20.00 | 36.00 / 20.00 |" in tshirt
    assert "| 0.30 / 2.50 | yes | -100.0 |" in tshirt
    assert "| **no** |" in dress                                            # its 3× run was not finite
    for name, garment in (("stability-tshirt.md", "tshirt"), ("stability-dress.md", "dress")):
        sub = (tmp_path / name).read_text()
        assert sub.startswith(f"# Stability: `assets/{garment}.pleat`") and "### (a) Long run" in sub
        assert f"images/stability_{garment}_long.png" in sub and "[stability.md](stability.md)" in sub
