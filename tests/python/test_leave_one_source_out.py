"""bench/leave_one_source_out.py: its rows per source from run folders' summaries, its table and the page block."""
import json

import pytest


@pytest.fixture(scope="module")
def loso(load_script):
    return load_script("bench/leave_one_source_out.py")


def _run(tmp_path, name, errors, frames):
    run = tmp_path / name
    run.mkdir()
    validation = [{"clip": clip, "pleat_mm": p, "lbs_mm": lbs} for clip, p, lbs in errors]
    (run / "simsup_summary.json").write_text(json.dumps({"validation": validation, "frames": frames}))
    return run


def test_rows_group_the_validation_clips_by_source_and_the_table_marks_the_held_out_one(loso, tmp_path):
    run = _run(tmp_path, "without_a", [("a/x", 10.0, 20.0), ("a/y", 30.0, 40.0), ("b/z", 5.0, 10.0)], 1234)
    rows = loso.rows("without:a", run)
    assert [(r["source"], len(r["clips"])) for r in rows] == [("a", 2), ("b", 1)]
    a = rows[0]
    assert a["pleat_mm"] == 20.0 and a["lbs_mm"] == 30.0 and a["ratio_to_lbs"] == pytest.approx(2 / 3)
    assert a["ratio_to_lbs_paired"] == pytest.approx((0.5 + 0.75) / 2)
    text = loso.table({"rows": rows})
    assert "| without a | **a** (never trained on) | 2 | 20.0 | 30.0 | 0.67 (0.62) | 1,234 |" in text
    assert "| without a | b | 1 | 5.0 | 10.0 | 0.50 (0.50) | 1,234 |" in text


def test_the_page_block_is_replaced_and_a_page_without_it_is_refused(loso):
    result = {"rows": [{"model": "all@36", "source": "a", "clips": ["a/x"], "pleat_mm": 1.0, "lbs_mm": 2.0,
                        "ratio_to_lbs": 0.5, "ratio_to_lbs_paired": 0.5, "training_frames": 10}]}
    page = f"intro\n{loso.BEGIN}\nold table\n{loso.END}\nafter\n"
    out = loso.with_table(page, result)
    assert out.startswith("intro\n") and out.endswith(f"{loso.END}\nafter\n") and "old table" not in out
    assert "| every source, 36 segments | a |" in out
    with pytest.raises(SystemExit):
        loso.with_table("no block here", result)
