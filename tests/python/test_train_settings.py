"""The training settings are declared once (pleat.train.settings): presets and --set only override the declared
defaults, unknown keys and values out of range are refused naming the key, `pleat-train config` shows what a run
resolves to, docs/settings.md carries the declarations' table, and pleat-train's commands each take their own
options (the older command lines still parse). No torch, no training: a few seconds."""
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from pleat.cli import InputError
from pleat.train import settings

REPO = Path(__file__).resolve().parents[2]
# What the training code used before the declarations, per preset and key: the preset's value, else the default
# written at the read (tools/pleat/train at 2d924f2, e.g. stage1.loss_norm_floor → 1.0 at six reads). The tiny
# preset's simsup.member_tier and simsup.second_student_tier are absent: it never reads them.
# Keys declared since then carry the value that does what the code did without them (simsup.contact_strain_weight
# = 0: no edge-length term).
BEFORE = json.loads((Path(__file__).parent / "train_config_before_settings.json").read_text())


@pytest.mark.parametrize("preset", ["default", "tiny"])
def test_presets_resolve_to_the_values_the_training_code_used_before(preset):
    cfg = settings.resolve(preset)
    for key, value in BEFORE[preset].items():
        got = settings.get(cfg, key)
        assert got == value and type(got) is type(value), f"{preset}: {key} = {got!r}, was {value!r}"
    assert set(BEFORE["default"]) == set(settings.BY_KEY), "every key the code reads is declared, and no other"


def test_every_declared_default_is_in_its_own_range_and_the_lists_match_the_code():
    for s in settings.SETTINGS:
        if s.default is not None:
            assert settings.check(s.key, s.default) == s.default, s.key
        assert s.meaning and s.values.text, s.key
    pytest.importorskip("torch")
    from pleat.train import model, simdata
    assert settings.VARIANTS == tuple(name for name, _ in simdata.VARIANTS)
    assert settings.ACTIVATIONS == tuple(model.ACTIVATIONS)


def test_unknown_keys_name_the_nearest_declared_key():
    for given, near in (("stage1.lrr", "stage1.lr"), ("lr", "stage1.lr"), ("stage1.contact_weight",
                                                                              "simsup.contact_weight"),
                        ("simsup.fitworkers", "simsup.fit_workers"), ("stage2.recod_group", "stage2.record_group")):
        with pytest.raises(settings.SettingError, match=f"unknown setting {re.escape(given)}; did you mean "
                                                        f"{re.escape(near)}\\?"):
            settings.resolve("tiny", overrides={given: 1})


def test_values_of_the_wrong_type_or_out_of_range_name_the_key_and_its_range():
    cases = {"stage1.iterations": (0, "integer >= 1"), "stage1.lr": (-1e-3, "number > 0"),
             "seed": (1.5, "integer >= 0"), "stage1.batched": (1, "true or false"),
             "stage1.w_inertia": ([1.0], "[number >= 0, number >= 0]"),
             "simsup.variants": (["original", "upside-down"], "non-empty ["), "stage1.loss_norm": ("none", '"lbs"'),
             "simsup.contact_candidates": (17, "integer in [0, 16]"), "model.activation": ("tanh", '"silu"'),
             "simsup.tier": ("huge", "tier name")}
    for key, (value, text) in cases.items():
        with pytest.raises(settings.SettingError, match=re.escape(f"{key} = {json.dumps(value)}: must be") + ".*"
                                                        + re.escape(text)):
            settings.resolve("tiny", overrides={key: value})
    with pytest.raises(settings.SettingError, match=r"model.mp_schedule = \[0, 1, 2, 1, 0\]: its levels must be "
                                                    r"below model.mp_levels = 2"):
        settings.resolve("tiny", overrides={"model.mp_schedule": [0, 1, 2, 1, 0]})
    assert settings.resolve("tiny", overrides={"fps": 25})["fps"] == 25.0, "an integer is a number"
    assert settings.resolve("tiny", overrides={"stage1": {"lr": 0.5}})["stage1"]["lr"] == 0.5, "a whole section"


def test_a_preset_file_with_an_unknown_key_is_an_input_error_naming_the_file(tmp_path):
    bad = tmp_path / "mine.json"
    bad.write_text(json.dumps({"stage1": {"iterations": 5, "windows_per_iter": 4}}))
    with pytest.raises(InputError, match=r"mine.json: unknown setting stage1.windows_per_iter; did you mean "
                                         r"stage1.windows_per_iteration\?"):
        settings.resolve(path=bad)
    good = tmp_path / "mine2.json"
    good.write_text(json.dumps({"stage1": {"iterations": 5}}))
    cfg = settings.resolve(path=good)
    assert cfg["preset"] == "mine2" and cfg["stage1"]["iterations"] == 5
    assert cfg["stage1"]["lr"] == settings.BY_KEY["stage1.lr"].default, "the rest at the declared defaults"


def test_a_stored_config_is_completed_in_place_with_the_declared_defaults():
    """A checkpoint written before a key was declared reads it at its default; what it holds stays as it is."""
    stored = json.loads((REPO / "configs" / "tiny.json").read_text())
    stored["stage1"]["retired_key"] = 3
    del stored["stage1"]["grad_clip"]
    same = settings.complete(stored)
    assert same is stored and stored["stage1"]["retired_key"] == 3
    assert stored["stage1"]["loss_norm_floor"] == 1.0 and stored["stage1"]["grad_clip"] == 1.0
    assert stored["stage2"]["record_group"] == 8 and stored["simsup"]["contact_iterations"] == 10


def test_the_training_code_reads_the_config_without_defaults_of_its_own():
    """No `.get(key, default)` on a config section in tools/pleat/train: the declaration is the one default."""
    leaf = {k.rsplit(".", 1)[-1] for k in settings.BY_KEY}
    found = []
    for path in (REPO / "tools" / "pleat" / "train").glob("*.py"):
        if path.name == "settings.py":
            continue
        for n, line in enumerate(path.read_text().splitlines(), 1):
            for var, key in re.findall(r"\b(cfg|c|c1|c2|ca|m|cfg\[\"\w+\"\])\.get\(\"(\w+)\"", line):
                if key in leaf:
                    found.append(f"{path.name}:{n}: {line.strip()}")
    assert not found, "\n".join(found)


def test_docs_presets_table_is_the_declarations():
    text = (REPO / "docs" / "settings.md").read_text()
    block = re.search(r"<!-- settings table: pleat-train config --markdown -->\n(.*?)\n<!-- /settings table -->",
                      text, re.S)
    assert block, "docs/settings.md has the settings table between its markers"
    assert block.group(1) == settings.markdown(), "regenerate it with pleat-train config --markdown"


# ---- the command line --------------------------------------------------------------------------------------------------
def _pleat_train(*argv):
    return subprocess.run([sys.executable, "-m", "pleat.train.cli", *argv], capture_output=True, text=True,
                          timeout=120, cwd=REPO)


def test_config_command_prints_each_key_with_its_value_origin_and_meaning():
    run = _pleat_train("config", "--preset", "default", "--set", "stage1.iterations=50")
    assert run.returncode == 0, run.stderr
    for s in settings.SETTINGS:
        assert re.search(rf"^  {re.escape(s.key)} ", run.stdout, re.M), s.key
    assert re.search(r"^  stage1\.iterations +50 \(--set\)$", run.stdout, re.M)
    assert re.search(r'^  stage1\.loss_norm +"lbs" \(default\.json\)$', run.stdout, re.M)
    assert "divide each window's loss by its LBS-only loss" in run.stdout
    as_json = _pleat_train("config", "--preset", "tiny", "--json")
    assert json.loads(as_json.stdout) == settings.resolve("tiny")


def test_bad_settings_on_the_command_line_are_one_error_line():
    run = _pleat_train("stage1", "--preset", "tiny", "--out", "/nonexistent/never", "--set", "stage1.lrr=1")
    errors = [line for line in run.stderr.splitlines() if "error" in line]
    assert run.returncode == 2 and errors == [
        "pleat-train stage1: error: --set: unknown setting stage1.lrr; did you mean stage1.lr? (pleat-train config "
        "lists them)"]
    run = _pleat_train("config", "--set", "stage1.iterations=0")
    assert run.returncode == 2 and "stage1.iterations = 0: must be integer >= 1" in run.stderr
    run = _pleat_train("config", "--preset", "nope")
    assert run.returncode == 1 and run.stderr.count("\n") == 1 and "no preset 'nope'" in run.stderr


def test_each_command_takes_its_own_options_and_older_command_lines_still_parse():
    from pleat.train.cli import build_parser
    parser = build_parser()
    old = [  # from docs/training.md, docs/accuracy.md, bench/ and the tests
        "stage1 --preset tiny --garment tshirt --out o --set stage1.iterations=50 --device cpu --max-minutes 1",
        "stage2 --preset tiny --garment tshirt --out o",
        "pack --preset tiny --garment tshirt --out o --model ablation --fp16 --onnx",
        "all --preset tiny --garment tshirt --out o --no-progress",
        "ablation --preset tiny --garment tshirt --out o --resume --seed 3",
        "simsup --preset default --garment tshirt --out o --max-minutes 110 --workers 2 --user-sim a.json --quiet",
        "simsup-tiers --out o --data d.npz --tiers small --tier-dir t --set simsup.iterations=2000",
        "simsup-contact --out o --data d.npz --from-asset a.pleat",
        "simsup-ensemble --members a b --out o",
        "contact-candidates --preset default --garment tshirt --data d.npz --out c.npz",
        "config --preset default --set stage1.iterations=5",
    ]
    for line in old:
        args = parser.parse_args(line.split())
        assert args.command == line.split()[0]
    for line in ("pack --out o --workers 2", "stage1 --out o --tiers small", "config --out o",
                 "simsup-tiers --out o --data d --user-sim x"):
        with pytest.raises(SystemExit):
            parser.parse_args(line.split())


def test_commands_on_an_existing_run_refuse_settings_they_would_ignore(tmp_path):
    pytest.importorskip("torch")          # pleat-train says it needs PyTorch before it reads the settings
    run = _pleat_train("simsup-tiers", "--out", str(tmp_path), "--data", "d.npz", "--set", "stage1.lr=0.1")
    assert run.returncode == 2 and "simsup-tiers takes only seed, simsup.iterations" in run.stderr
    run = _pleat_train("simsup-contact", "--out", str(tmp_path), "--data", "d.npz", "--set", "simsup.lr=0.1")
    assert run.returncode == 2 and "simsup-contact takes only simsup.contact_iterations" in run.stderr
