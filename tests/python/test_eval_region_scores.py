"""Per-region scores: metrics.score_regions on a hand-made square whose numbers are known, the suite's per-region
means and ratios, and pleat-eval's report carrying them (with the reference replaced by the LBS garment)."""
import json

import numpy as np
import pytest

from pleat.eval import metrics
from pleat.eval.suite import summarise

# A 10 cm square of two triangles; edges (0,1) (0,2) (0,3) (1,2) (2,3). Region "left" = vertices 0, 1 (one edge
# inside: 0–1), "right" = 2, 3 (one edge: 2–3).
REST = 0.1 * np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
FACES = np.array([[0, 1, 2], [0, 2, 3]])
REGIONS = {"all": np.ones(4, bool), "left": np.array([1, 1, 0, 0], bool), "right": np.array([0, 0, 1, 1], bool),
           "empty": np.zeros(4, bool)}


def _case():
    ref = np.stack([REST, REST])
    pred = ref.copy()
    pred[:, 1, 0] += 0.01          # vertex 1 moved 10 mm along x in both frames: edge 0–1 stretched by 10 %
    sd = 0.001 * np.array([[-1.0, 1.0, 1.0, 1.0], [1.0, 1.0, -1.0, 1.0]])     # one left, one right vertex inside
    return pred, ref, sd


def test_region_numbers_of_a_known_case():
    pred, ref, sd = _case()
    r = metrics.score_regions(pred, ref, FACES, REST, REGIONS, sd)
    left, right = r["left"], r["right"]
    assert (left["vertices"], left["edges"], right["vertices"], right["edges"]) == (2, 1, 2, 1)
    assert left["mean_mm"] == pytest.approx(5.0) and left["p95_mm"] == pytest.approx(10.0)
    assert left["edge_strain_error"] == pytest.approx(0.1)
    assert right["mean_mm"] == 0.0 and right["p95_mm"] == 0.0 and right["edge_strain_error"] == pytest.approx(0.0)
    assert left["penetration_pct"] == pytest.approx(25.0) and right["penetration_pct"] == pytest.approx(25.0)
    # the whole garment's region gives score's own numbers
    s = metrics.score(pred, ref, FACES, REST, 1 / 30, sd)
    for k in ("mean_mm", "p95_mm", "edge_strain_error", "penetration_pct"):
        assert r["all"][k] == pytest.approx(s[k])
    assert r["all"]["edges"] == 5
    # an empty region says so with nulls (JSON-safe), never NaN
    assert r["empty"] == {"vertices": 0, "edges": 0, "mean_mm": None, "p95_mm": None, "edge_strain_error": None,
                          "penetration_pct": None}
    assert "penetration_pct" not in metrics.score_regions(pred, ref, FACES, REST, REGIONS)["left"]


def _row(clip, pleat_left, lbs_left):
    def method(mean, base):
        return {"mean_mm": base, "p95_mm": 2 * base, "penetration_pct": 1.0, "jitter": 1.0, "step_us": 10.0,
                "regions": {"left": {"vertices": 2, "edges": 1, "mean_mm": mean, "p95_mm": 2 * mean,
                                     "edge_strain_error": 0.01 * mean, "penetration_pct": 0.5}}}
    return {"clip": clip, "pleat": method(pleat_left, 4.0), "lbs": method(lbs_left, 8.0),
            "reference": {"penetration": {"penetration_pct": 0.2}}}


def test_suite_summary_has_per_region_means_beside_lbs_and_the_ratio():
    s = summarise([_row("a", 2.0, 4.0), _row("b", 6.0, 8.0)])
    g = s["regions"]["left"]
    assert g["vertices"] == 2
    assert g["mean_mm"] == pytest.approx(4.0) and g["lbs_mean_mm"] == pytest.approx(6.0)
    assert g["p95_mm"] == pytest.approx(8.0) and g["lbs_p95_mm"] == pytest.approx(12.0)
    assert g["edge_strain_error"] == pytest.approx(0.04) and g["lbs_edge_strain_error"] == pytest.approx(0.06)
    assert g["penetration_pct"] == pytest.approx(0.5) and g["lbs_penetration_pct"] == pytest.approx(0.5)
    assert g["ratio_to_lbs"] == pytest.approx(4.0 / 6.0)
    assert g["ratio_to_lbs_paired"] == pytest.approx(0.5 * (2 / 4 + 6 / 8))
    assert s["ratio_to_lbs"] == pytest.approx(0.5)          # the garment-wide numbers are as before
    # rows written before per-region scores existed: the summary is what it was
    old = [_row("a", 2.0, 4.0)]
    for m in ("pleat", "lbs"):
        del old[0][m]["regions"]
    assert "regions" not in summarise(old)


def test_pleat_eval_reports_regions(monkeypatch, tmp_path, c_runtime):
    """With the reference replaced by the LBS garment, LBS-only scores 0 mm in every region of the t-shirt."""
    from pleat import REPO_ROOT
    from pleat.eval import cli
    from pleat.eval import scene as S
    asset = REPO_ROOT / "assets" / "tshirt.pleat"
    if not asset.is_file() or not (REPO_ROOT / "assets" / "body.npz").is_file():
        pytest.skip("assets/tshirt.pleat or assets/body.npz missing")

    def fake_reference(garment, body, clip, beta, material, frames=None, start_perturbation_m=0.0, **kw):
        _, M = S.posed_body(body, clip, beta)
        return garment.skin(M, beta).astype(np.float32), dict(key="fake", cache_hit=False)
    monkeypatch.setattr("pleat.eval.reference.cached_simulate", fake_reference)
    out = tmp_path / "r.json"
    cli.main(["--asset", str(asset), "--motion", "deepmimic_pybullet/humanoid3d_punch", "--max-frames", "4",
              "--json", str(out), "--no-progress"])
    r = json.loads(out.read_text())
    assert set(r["region_vertices"]) == {"all", "sleeves", "torso"}
    assert r["region_vertices"]["sleeves"] + r["region_vertices"]["torso"] == r["vertices"]
    for m in ("pleat", "lbs"):
        assert set(r[m]["regions"]) == {"all", "sleeves", "torso"}
        assert r[m]["regions"]["all"]["mean_mm"] == pytest.approx(r[m]["mean_mm"])
        for g in r[m]["regions"].values():
            assert all(np.isfinite(g[k]) for k in ("mean_mm", "p95_mm", "edge_strain_error", "penetration_pct"))
    assert r["lbs"]["regions"]["sleeves"]["mean_mm"] < 1e-3


def test_suite_summary_gives_the_faces_share_inside_the_body_when_every_run_has_it():
    rows = [_row("a", 2.0, 4.0), _row("b", 6.0, 8.0)]
    assert "surface_inside_pct" not in summarise(rows)                # older reports: nothing made up
    for r, (p, lbs, ref) in zip(rows, ((1.0, 3.0, 0.5), (2.0, 5.0, 1.5))):
        r["pleat"]["surface_inside"] = {"inside_pct": p}
        r["lbs"]["surface_inside"] = {"inside_pct": lbs}
        r["reference"]["surface_inside"] = {"inside_pct": ref}
    s = summarise(rows)
    assert (s["surface_inside_pct"], s["lbs_surface_inside_pct"], s["reference_surface_inside_pct"]) == (1.5, 4.0, 1.0)
