"""README.md's numbers block is what scripts/docs-numbers.py writes from the committed JSON
(bench/results/cpu-reference.json, accuracy-reference.json): a figure changed by hand, or a JSON updated without
rerunning the script, fails here."""
import importlib.util
import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def docs_numbers():
    spec = importlib.util.spec_from_file_location("docs_numbers", ROOT / "scripts" / "docs-numbers.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


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
