"""README.md's numbers block and docs/accuracy.md's garments table are what scripts/docs-numbers.py writes from the
committed JSON (bench/results/cpu-reference.json, accuracy-reference.json, accuracy-garments.json): a figure changed
by hand, or a JSON updated without rerunning the script, fails here. The conversion of pleat-eval-suite reports into
accuracy-garments.json (--garments-from) is checked on a small synthetic report."""
import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def docs_numbers(load_script):
    return load_script("scripts/docs-numbers.py")


def test_readme_block_equals_what_the_script_writes_from_the_committed_json(docs_numbers):
    bench, accuracy = docs_numbers.load()
    readme = (ROOT / "README.md").read_text()
    assert docs_numbers.splice(readme, docs_numbers.render(bench, accuracy)) == readme, \
        "README.md's numbers block is stale: run scripts/docs-numbers.py"
    assert docs_numbers.main(["--check"]) == 0


def test_a_hand_edited_figure_is_caught(docs_numbers, tmp_path):
    readme = (ROOT / "README.md").read_text()
    edited = tmp_path / "README.md"
    edited.write_text(readme.replace("mlp_speedup` **", "mlp_speedup` **9", 1))
    assert edited.read_text() != readme
    assert docs_numbers.main(["--check", "--readme", str(edited)]) == 1
    assert docs_numbers.main(["--readme", str(edited)]) == 0
    assert edited.read_text() == readme


def test_every_time_names_its_cpu_isa_and_load(docs_numbers):
    bench, accuracy = docs_numbers.load()
    block = docs_numbers.render(bench, accuracy)
    machine = bench["machine"]
    for line in block.splitlines():
        if "µs" in line and line.startswith("- "):
            assert machine["cpu"] in line and machine["isa"] in line and "load" in line, line
    assert "scripts/bench.sh" in block and "ratios" in block


def test_a_new_measurement_changes_the_block(docs_numbers, tmp_path):
    bench, accuracy = docs_numbers.load()
    bench["machine"]["cpu"] = "Test CPU 9000"
    bench["mlp_speedup"] = 1.5
    path = tmp_path / "step.json"
    path.write_text(json.dumps(bench))
    block = docs_numbers.render(*docs_numbers.load(path, docs_numbers.ACCURACY_JSON))
    assert "Test CPU 9000" in block and re.search(r"\*\*1\.50×\*\*", block)


def test_a_readme_without_markers_is_an_error(docs_numbers, tmp_path):
    plain = tmp_path / "README.md"
    plain.write_text("# no block\n")
    assert docs_numbers.main(["--check", "--readme", str(plain)]) == 2


# --- docs/accuracy.md: the table of garments and tiers (bench/results/accuracy-garments.json) ----------------------

def test_accuracy_page_block_equals_what_the_script_writes_from_the_committed_json(docs_numbers):
    page = (ROOT / "docs" / "accuracy.md").read_text()
    block = docs_numbers.render_garments(docs_numbers.load_garments())
    assert docs_numbers.splice(page, block, docs_numbers.GARMENTS_BEGIN, docs_numbers.GARMENTS_END) == page, \
        "docs/accuracy.md's garments table is stale: run scripts/docs-numbers.py"


def test_a_hand_edited_accuracy_table_is_caught_and_rewritten(docs_numbers, tmp_path):
    page = (ROOT / "docs" / "accuracy.md").read_text()
    edited = tmp_path / "accuracy.md"
    edited.write_text(page.replace("| tshirt | large |", "| tshirt | large (edited) |", 1))
    assert edited.read_text() != page
    assert docs_numbers.main(["--check", "--accuracy-page", str(edited)]) == 1
    assert docs_numbers.main(["--accuracy-page", str(edited)]) == 0
    assert edited.read_text() == page


def test_every_committed_garment_row_has_the_columns_the_page_shows(docs_numbers):
    rows = docs_numbers.load_garments()["rows"]
    assert rows, "bench/results/accuracy-garments.json has no rows"
    for row in rows:
        for key in ("garment", "tier", "asset", "vertices", "command", "regions", "step_machine",
                    "training_cpu_hours", "edge_strain_error", "lbs_edge_strain_error") + docs_numbers.SUMMARY_KEYS:
            assert key in row, (row.get("garment"), row.get("tier"), key)


def _run(clip, beta, pleat_mm, lbs_mm, spread_mm=None):
    """One run of a pleat-eval-suite report, reduced to the keys the conversion reads."""
    return {"clip": clip, "beta": beta, "frames": 60, "garment": "dress", "vertices": 400,
            "pleat": {"mean_mm": pleat_mm}, "lbs": {"mean_mm": lbs_mm},
            "reference_spread": None if spread_mm is None else {"mean_mm": spread_mm}}


def _synthetic_suite(tmp_path):
    """Two assets of one garment (the top tier and a cheaper one) in the shape pleat-eval-suite writes."""
    regions = {"all": {"vertices": 400, "mean_mm": 20.0, "p95_mm": 40.0, "edge_strain_error": 0.031,
                       "lbs_edge_strain_error": 0.052, "penetration_pct": 0.5, "lbs_penetration_pct": 2.0,
                       "lbs_mean_mm": 30.0, "lbs_p95_mm": 60.0, "ratio_to_lbs": 0.667, "ratio_to_lbs_paired": 0.66},
               "skirt": {"vertices": 259, "mean_mm": 28.0, "p95_mm": 55.0, "edge_strain_error": 0.04,
                         "lbs_edge_strain_error": 0.06, "penetration_pct": 0.1, "lbs_penetration_pct": 0.3,
                         "lbs_mean_mm": 35.0, "lbs_p95_mm": 70.0, "ratio_to_lbs": 0.8, "ratio_to_lbs_paired": 0.82},
               "bodice": {"vertices": 147, "mean_mm": 9.0, "p95_mm": 20.0, "edge_strain_error": 0.02,
                          "lbs_edge_strain_error": 0.04, "penetration_pct": 1.2, "lbs_penetration_pct": 4.0,
                          "lbs_mean_mm": 20.0, "lbs_p95_mm": 40.0, "ratio_to_lbs": 0.45, "ratio_to_lbs_paired": 0.44}}
    summary = {"runs": 2, "mean_mm": 20.0, "p95_mm": 40.0, "lbs_mean_mm": 30.0, "lbs_p95_mm": 60.0,
               "ratio_to_lbs": 0.6667, "ratio_to_lbs_paired": 0.66, "worst_ratio_to_lbs": 0.7,
               "clips_worse_than_lbs": [], "penetration_pct": 0.5, "lbs_penetration_pct": 2.0,
               "reference_penetration_pct": 0.8, "jitter": 3.0, "lbs_jitter": 2.5, "step_us": 55.25,
               "spread_mean_mm": 10.0, "ratio_to_spread": 2.0, "regions": regions}
    runs = [_run("deepmimic_github/humanoid3d_jog", [0.0, 0.0], 18.0, 28.0, 9.0),
            _run("deepmimic_github/humanoid3d_jog", [1.5, -1.0], 22.0, 32.0, 11.0)]
    cheap = dict(summary, mean_mm=24.0, ratio_to_lbs_paired=0.8, step_us=20.0, regions={})
    suite = {"out/dress.pleat": {"summary": summary, "runs": runs},
             "out/dress_small.pleat": {"summary": cheap, "runs": runs}}
    path = tmp_path / "suite.json"
    path.write_text(json.dumps(suite))
    return path


def test_garments_from_a_suite_gives_a_row_per_garment_and_tier(docs_numbers, tmp_path):
    path = _synthetic_suite(tmp_path)
    metas = {"out/dress.pleat": {"garment": "dress", "tier": "large", "vertices": 400,
                                 "training": {"cpu_hours": 3.456, "simulation_cpu_h": 2.5}},
             "out/dress_small.pleat": {}}       # no META: the report names the garment, the file name the tier
    garments = docs_numbers.garments_from_suites([path], machine="Test CPU, 2 cores", metas=metas)
    rows = garments["rows"]
    assert [(r["garment"], r["tier"]) for r in rows] == [("dress", "large"), ("dress", "small")]
    large, small = rows
    assert large["vertices"] == 400 and large["runs"] == 2 and large["clips"] == 1 and large["betas"] == 2
    assert large["mean_mm"] == 20.0 and large["ratio_to_lbs_paired"] == 0.66 and large["ratio_to_spread"] == 2.0
    assert large["edge_strain_error"] == 0.031 and large["lbs_edge_strain_error"] == 0.052
    assert large["step_us"] == 55.25 and large["step_machine"] == "Test CPU, 2 cores"
    assert large["training_cpu_hours"] == 3.46 and large["simulation_cpu_hours"] == 2.5
    assert set(large["regions"]) == {"skirt", "bodice"}                 # "all" is the row itself
    assert large["regions"]["skirt"]["ratio_to_lbs_paired"] == 0.82
    assert "jitter" not in large
    assert small["training_cpu_hours"] is None and small["regions"] == {} and small["mean_mm"] == 24.0
    command = large["command"]
    assert command.startswith("PLEAT_LIBRARY=build/eval/libpleat.so pleat-eval-suite --assets out/dress.pleat")
    assert "--betas '0;1.5,-1'" in command and "--reference-spread" in command
    assert "--clips deepmimic_github/humanoid3d_jog" in command

    block = docs_numbers.render_garments(garments)
    assert "| dress | large | 400 | 2 | **20.0** / 40.0 | 0.67 (0.66; 0.70) | 2.00 (10.0) |" in block
    assert "| 0.031 / 0.052 | 55.2 | 3.46 (2.50 of them simulating) |" in block
    assert "Test CPU, 2 cores" in block
    skirt = block.index("| dress | large | skirt |")
    assert skirt < block.index("| dress | large | bodice |"), "the hardest region (against LBS-only) comes first"


def test_garments_from_writes_the_json_and_the_page(docs_numbers, tmp_path):
    path = _synthetic_suite(tmp_path)
    out = tmp_path / "accuracy-garments.json"
    page = tmp_path / "accuracy.md"
    page.write_text(f"# x\n{docs_numbers.GARMENTS_BEGIN}\nold\n{docs_numbers.GARMENTS_END}\nafter\n")
    readme = tmp_path / "README.md"
    readme.write_text((ROOT / "README.md").read_text())
    no_teachers = ["--teachers", str(tmp_path / "no-teachers.json")]     # this page has no teachers block
    assert docs_numbers.main(["--garments-from", str(path), "--machine", "Test CPU", "--garments", str(out),
                              "--accuracy-page", str(page), "--readme", str(readme), *no_teachers]) == 0
    rows = json.loads(out.read_text())["rows"]
    assert {(r["garment"], r["tier"]) for r in rows} == {("dress", "large"), ("dress", "small")}
    text = page.read_text()
    assert "old" not in text and "| dress | small |" in text and text.endswith(f"{docs_numbers.GARMENTS_END}\nafter\n")
    assert docs_numbers.main(["--check", "--garments", str(out), "--accuracy-page", str(page),
                              "--readme", str(readme), *no_teachers]) == 0


def test_teachers_from_suites_gives_a_row_per_asset_and_reference_and_both_blocks_share_the_page(docs_numbers,
                                                                                                  tmp_path):
    """--teachers-from: suites of assets trained on either simulator, each scored against either, become
    accuracy-teachers.json and docs/accuracy.md's table, next to the garments block on the same page."""
    paths = []
    for reference in ("pleat", "blender"):
        runs = [dict(_run("deepmimic_github/humanoid3d_jog", [0.0], 18.0, 28.0, 9.0), reference={"teacher": reference})
                for _ in range(2)]
        summary = {"runs": 2, "mean_mm": 18.0 if reference == "blender" else 14.0, "ratio_to_lbs_paired": 0.5}
        suite = {"out/b.pleat": {"summary": summary, "runs": runs}, "assets/tshirt.pleat": {"summary": summary,
                                                                                          "runs": runs}}
        paths.append(tmp_path / f"suite_{reference}.json")
        paths[-1].write_text(json.dumps(suite))
    metas = {"out/b.pleat": {"garment": "tshirt", "training": {"simulator": "blender", "frames": 9000}},
             "assets/tshirt.pleat": {"garment": "tshirt", "training": {"frames": 39559}}}
    teachers = docs_numbers.teachers_from_suites(paths, machine="Test CPU", metas=metas)
    rows = [(r["reference"], r["asset"], r["trained_on"], r["training_frames"]) for r in teachers["rows"]]
    assert rows == [("blender", "out/b.pleat", "blender", 9000), ("blender", "assets/tshirt.pleat", "pleat", 39559),
                    ("pleat", "assets/tshirt.pleat", "pleat", 39559), ("pleat", "out/b.pleat", "blender", 9000)]
    assert "--reference blender" in teachers["rows"][0]["command"]
    assert "--reference " not in teachers["rows"][2]["command"]
    block = docs_numbers.render_teachers(teachers)
    assert "| Blender's cloth | not shipped (`b.pleat`) | Blender's cloth (9,000) | 2 | **18.0** /" in block
    assert "| Pleat's simulator | `assets/tshirt.pleat` | Pleat's simulator (39,559) |" in block
    # an asset whose META predates training.simulator: its run folder's config says which simulator taught it
    run = tmp_path / "run"
    run.mkdir()
    (run / "config_simsup.json").write_text(json.dumps({"config": {"simsup": {"teacher": "blender"}}}))
    assert docs_numbers._run_teacher(str(run / "b.pleat")) == "blender"
    assert docs_numbers._run_teacher(str(tmp_path / "b.pleat")) is None
    mixed = [dict(r, reference={"teacher": t}) for r, t in zip(runs, ("pleat", "blender"))]
    paths[0].write_text(json.dumps({"out/b.pleat": {"summary": summary, "runs": mixed}}))
    with pytest.raises(ValueError, match="several references"):
        docs_numbers.teachers_from_suites(paths[:1], machine="Test CPU", metas=metas)

    page = tmp_path / "accuracy.md"
    page.write_text(f"{docs_numbers.GARMENTS_BEGIN}\nold\n{docs_numbers.GARMENTS_END}\nmiddle\n"
                    f"{docs_numbers.TEACHERS_BEGIN}\nold\n{docs_numbers.TEACHERS_END}\n")
    out = tmp_path / "teachers.json"
    out.write_text(json.dumps(teachers))
    readme = tmp_path / "README.md"
    readme.write_text((ROOT / "README.md").read_text())
    common = ["--teachers", str(out), "--accuracy-page", str(page), "--readme", str(readme)]
    assert docs_numbers.main(common) == 0
    text = page.read_text()
    assert "old" not in text
    assert "\nmiddle\n" in text and "| Blender's cloth | not shipped (`b.pleat`) |" in text
    assert "| garment | tier |" in text                  # both blocks written, neither over the other
    assert docs_numbers.main(["--check", *common]) == 0


def test_garments_from_refreshes_its_rows_and_keeps_the_other_garments(docs_numbers, tmp_path):
    path = _synthetic_suite(tmp_path)
    out = tmp_path / "accuracy-garments.json"
    kept = {"garment": "tshirt", "tier": "large", "mean_mm": 13.1}
    stale = {"garment": "dress", "tier": "large", "mean_mm": 99.0}
    out.write_text(json.dumps({"about": "x", "rows": [stale, kept]}))
    new = docs_numbers.garments_from_suites([path], machine="Test CPU")
    rows = docs_numbers.merged(json.loads(out.read_text()), new)["rows"]
    assert [(r["garment"], r["tier"]) for r in rows] == [("dress", "large"), ("dress", "small"), ("tshirt", "large")]
    assert rows[0]["mean_mm"] == 20.0 and rows[2] == kept


def test_garments_page_surface_table_equals_the_committed_json(docs_numbers):
    surface = json.loads(docs_numbers.SURFACE_JSON.read_text())
    page = docs_numbers.GARMENTS_PAGE.read_text()
    assert docs_numbers.splice(page, docs_numbers.render_surface(surface), docs_numbers.SURFACE_BEGIN,
                               docs_numbers.SURFACE_END) == page, "docs/garments.md's table is stale"
    assert {r["garment"] for r in surface["rows"]} == {"tshirt", "tank_top", "long_sleeve", "pants", "dress"}


def test_surface_from_pleat_sim_summaries_writes_the_json_and_the_table(docs_numbers, tmp_path):
    summary = {"garment": "skirt", "vertices": 864, "motion": "walk", "frames": 30,
               "surface_inside": {"frames": 10, "samples_per_face": 15, "depth_mm": 1.0, "inside_pct": 1.23456,
                                  "worst_frame_inside_pct": 2.5, "median_depth_mm": 3.21, "max_depth_mm": 9.87}}
    (tmp_path / "summary.json").write_text(json.dumps(summary))
    page = tmp_path / "garments.md"
    page.write_text(f"before\n{docs_numbers.SURFACE_BEGIN}\nold\n{docs_numbers.SURFACE_END}\nafter\n")
    out = tmp_path / "surface.json"
    pages = []
    for name in ("README.md", "docs/accuracy.md"):
        pages.append(tmp_path / Path(name).name)
        pages[-1].write_text((ROOT / name).read_text())
    assert docs_numbers.main(["--surface-from", str(tmp_path / "summary.json"), "--surface", str(out),
                              "--garments-page", str(page), "--readme", str(pages[0]),
                              "--accuracy-page", str(pages[1])]) == 0
    assert json.loads(out.read_text())["rows"][0]["inside_pct"] == 1.235
    text = page.read_text()
    assert "| skirt | 864 | 1.24 | 2.50 | 3.2 | 9.9 |" in text and "old" not in text and text.endswith("after\n")
    # a summary from before the measure existed is refused, naming the file
    del summary["surface_inside"]
    (tmp_path / "summary.json").write_text(json.dumps(summary))
    assert docs_numbers.main(["--surface-from", str(tmp_path / "summary.json"), "--surface", str(out),
                              "--garments-page", str(page), "--readme", str(pages[0]),
                              "--accuracy-page", str(pages[1])]) == 2


def _wardrobe_report(runner, cpus, wall, walls):
    return {"runner": runner, "cpus": cpus, "address": None, "preset": "tiny", "overrides": {}, "tiers": ["xsmall"],
            "wall_s": wall, "hardware": {}, "garments": [
                {"garment": g, "wall_s": w, "segments": 3, "frames": 36, "simulation_cpu_h": 0.001,
                 "verdict": "verdict: BETTER"} for g, w in walls.items()]}


def test_wardrobe_from_reports_writes_the_json_and_the_table(docs_numbers, tmp_path):
    """--wardrobe-from: serial and Ray pleat-wardrobe reports become bench/results/wardrobe.json and training.md's
    table, Ray's wall time as a ratio to serial's; reports of different garments are refused."""
    paths = []
    for name, report in (("serial", _wardrobe_report("serial", 1, 200.0, {"tshirt": 90.0, "dress": 110.0})),
                         ("ray", _wardrobe_report("ray", 2, 125.0, {"tshirt": 100.0, "dress": 120.0}))):
        paths.append(tmp_path / f"{name}.json")
        paths[-1].write_text(json.dumps(report))
    page = tmp_path / "training.md"
    page.write_text(f"before\n{docs_numbers.WARDROBE_BEGIN}\nold\n{docs_numbers.WARDROBE_END}\nafter\n")
    pages = []
    for name in ("README.md", "docs/accuracy.md"):
        pages.append(tmp_path / Path(name).name)
        pages[-1].write_text((ROOT / name).read_text())
    out = tmp_path / "wardrobe.json"
    common = ["--wardrobe", str(out), "--training-page", str(page), "--readme", str(pages[0]),
              "--accuracy-page", str(pages[1]), "--machine", "a test CPU"]
    assert docs_numbers.main(["--wardrobe-from", *map(str, paths), *common]) == 0
    assert [r["runner"] for r in json.loads(out.read_text())["runs"]] == ["serial", "ray"]
    text = page.read_text()
    assert "| serial | 1 | 90 | 110 | **200** | 1 |" in text and "| ray | 2 | 100 | 120 | **125** | 1.60× faster |" \
        in text and "a test CPU" in text and "old" not in text
    other = _wardrobe_report("ray", 2, 125.0, {"pants": 100.0})
    paths[1].write_text(json.dumps(other))
    assert docs_numbers.main(["--wardrobe-from", *map(str, paths), *common]) == 2


def test_int8_from_reports_writes_a_row_per_int8_asset_and_the_float_baseline(docs_numbers, tmp_path):
    """--int8-from: bench/int8_accuracy.py reports and a suite become int8-accuracy.json and docs/performance.md's
    table; how each asset was made comes from its META; reports against different float assets are refused."""
    paths = []
    for name, mean in (("ptq", 0.33), ("qat", 0.22)):
        paths.append(tmp_path / f"acc_{name}.json")
        paths[-1].write_text(json.dumps(dict(float_asset="assets/tshirt.pleat", int8_asset=f"out/{name}.pleat",
                                             mean_mm=mean, p99_mm=1.0, max_mm=9.0)))
    suite = {a: {"summary": {"mean_mm": m, "jitter": j}, "runs": [_run("deepmimic_github/humanoid3d_jog", [0.0], m,
                                                                       20.0, 9.0)]}
             for a, m, j in (("assets/tshirt.pleat", 13.65, 2.81), ("out/ptq.pleat", 13.66, 2.85),
                             ("out/qat.pleat", 13.65, 2.84))}
    (tmp_path / "suite.json").write_text(json.dumps(suite))
    metas = {"out/ptq.pleat": {"int8": {"inputs": "ranged"}},
             "out/qat.pleat": {"int8": {"inputs": "ranged"}, "int8_finetune": {"smoothness": 3.0, "ranged": True}}}
    int8 = docs_numbers.int8_from_reports(paths, [tmp_path / "suite.json"], machine="Test CPU", metas=metas)
    assert [(r["made"], r["error_mm"], r["jitter"]) for r in int8["rows"]] == [
        ("pleat-pack --int8", 13.66, 2.85), ("pleat-quantise finetune --smoothness 3", 13.65, 2.84)]
    assert int8["float_jitter"] == 2.81
    block = docs_numbers.render_int8(int8)
    assert "| `pleat-quantise finetune --smoothness 3` | ranged | **0.220** / 1.00 / 9.0 | 13.65 | 2.840 |" in block
    assert "| the float asset (`assets/tshirt.pleat`) | — | — | 13.65 | 2.810 |" in block
    other = tmp_path / "acc_other.json"
    other.write_text(json.dumps(dict(float_asset="assets/dress.pleat", int8_asset="out/d.pleat", mean_mm=0.3,
                                     p99_mm=1.0, max_mm=2.0)))
    with pytest.raises(ValueError, match="different float assets"):
        docs_numbers.int8_from_reports(paths + [other], [tmp_path / "suite.json"], metas=metas)
    # int8 blend shapes: on int8 networks and on fp16 ones; a later report adds its rows and refreshes its own
    shapes = tmp_path / "acc_shapes.json"
    shapes.write_text(json.dumps(dict(float_asset="assets/tshirt.pleat", int8_asset="out/shapes.pleat", mean_mm=0.16,
                                      p99_mm=0.4, max_mm=11.0)))
    again = tmp_path / "acc_ptq_again.json"
    again.write_text(json.dumps(dict(float_asset="assets/tshirt.pleat", int8_asset="out/ptq.pleat", mean_mm=0.38,
                                     p99_mm=1.7, max_mm=30.0)))
    metas2 = {"out/shapes.pleat": {"int8_blend_shapes": {"scales": "one per shape"}},
              "out/ptq.pleat": {"int8": {"inputs": "ranged"}, "int8_blend_shapes": {"scales": "one per shape"}}}
    later = docs_numbers.int8_from_reports([shapes, again], [tmp_path / "suite.json"], machine="Test CPU",
                                           metas=metas2)
    rows = docs_numbers.merged_int8(int8, later)["rows"]
    assert [(r["asset"], r["made"], r["inputs"], r["mean_mm"]) for r in rows] == [
        ("out/qat.pleat", "pleat-quantise finetune --smoothness 3", "ranged", 0.22),
        ("out/shapes.pleat", "pleat-pack --fp16 --int8-blend-shapes", "—", 0.16),
        ("out/ptq.pleat", "pleat-pack --int8 --int8-blend-shapes", "ranged", 0.38)]
