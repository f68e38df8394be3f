"""Every shipped garment comes as a tier ladder (assets/NAME.pleat, NAME_small.pleat, NAME_xsmall.pleat; the t-shirt
also NAME_medium.pleat) that a scene takes as it is: the same garment and skeleton in every tier, the cheaper tiers
smaller, and `pleat-render --crowd` (plCreateScene, plScene_Step under a budget that makes it mix tiers) runs each
ladder end to end (docs/scene-budget.md)."""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pleat.eval import scene as S

ROOT = Path(__file__).resolve().parents[2]
TIERS = ("medium", "small", "xsmall")
GARMENTS = sorted(p.stem for p in (ROOT / "assets").glob("*.pleat")
                  if not p.stem.endswith(tuple(f"_{t}" for t in TIERS)))


def _ladder(garment):
    return [ROOT / "assets" / f"{garment}.pleat"] + [ROOT / "assets" / f"{garment}_{t}.pleat" for t in TIERS
                                                     if (ROOT / "assets" / f"{garment}_{t}.pleat").is_file()]


def test_the_five_garments_each_have_a_small_and_an_xsmall_tier():
    assert set(GARMENTS) == {"tshirt", "dress", "pants", "long_sleeve", "tank_top"}
    for g in GARMENTS:
        names = [p.stem for p in _ladder(g)]
        assert f"{g}_small" in names and f"{g}_xsmall" in names, names


@pytest.mark.parametrize("garment", GARMENTS)
def test_a_ladder_is_one_garment_on_one_skeleton_getting_cheaper(garment):
    ladder = [S.read_weights(p)[1] for p in _ladder(garment)]
    for w in ladder:
        assert str(w["garment_name"]) == garment
        assert list(w["joint_names"]) == list(ladder[0]["joint_names"])
        assert np.array_equal(w["joint_parents"], ladder[0]["joint_parents"])
    sizes = [sum(np.asarray(w[k]).size for k in w if k.startswith(("lp.", "dec.")) and k.endswith("weight"))
             for w in ladder]
    assert sizes == sorted(sizes, reverse=True) and sizes[-1] < sizes[0] / 10, sizes
    assert len(ladder[-1]["template"]) < len(ladder[0]["template"]) / 4         # xsmall: its coarse remesh


def _render():
    build = os.environ.get("PLEAT_BUILD_DIR")
    exe = Path(build) / "samples" / "pleat-render" if build else None
    if exe is None or not exe.is_file():
        pytest.skip("pleat-render not built (set PLEAT_BUILD_DIR)")
    return exe


@pytest.mark.parametrize("garment", GARMENTS)
def test_pleat_render_crowd_runs_each_ladder_as_a_scene(garment, tmp_path):
    exe = _render()
    ladder = _ladder(garment)
    env = dict(os.environ, PYTHONPATH=str(ROOT / "tools"))
    for cmd in (["body", "--stick", "--asset", str(ladder[0]), "--out", str(tmp_path / "body.bin")],
                ["motion", "--random", "6", "--asset", str(ladder[0]), "--out", str(tmp_path / "clip.bin")]):
        subprocess.run([sys.executable, "-m", "pleat.render_export", *cmd], check=True, env=env,
                       capture_output=True)
    # 8 characters under a budget below the top tier's cost for all of them: the scene has to mix tiers
    r = subprocess.run([str(exe), "--crowd", "8", "--tiers", ",".join(map(str, ladder)), "--bodies",
                        str(tmp_path / "body.bin"), "--clips", str(tmp_path / "clip.bin"), "--budget-us", "300",
                        "--out", str(tmp_path / "crowd"), "--size", "160x120", "--frames", "5", "--step", "4",
                        "--sheet", "2"], capture_output=True, text=True)
    if r.returncode == 77:
        pytest.skip("no GL for the renderer here")
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "crowd" / "crowd_sheet.png").stat().st_size > 0
    assert "plScene_Step mean" in r.stdout + r.stderr
