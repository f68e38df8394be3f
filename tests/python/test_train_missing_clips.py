"""Training with the clips that are there: a motion folder that lacks some of the split's clips (the GitHub takes that
scripts/fetch-motion.sh could not fetch) names them in `pleat-motion list` and `pleat.motion.split.missing`;
training's clip list is the rest, with one warning; `--user-sim-only` needs no clip at all; the user's files are
checked first, and a failed run leaves its output folder as it was."""
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from pleat.cli import InputError
from pleat.motion import split
from pleat.paths import REPO_ROOT

SHIPPED = REPO_ROOT.parent / "shared" / "motion"


@pytest.fixture
def motion_dir(tmp_path, monkeypatch):
    """A motion folder with only the pybullet clips (what a fetch without GitHub leaves), as $PLEAT_MOTION_DIR."""
    if not (SHIPPED / "deepmimic_pybullet").is_dir():
        pytest.skip("no shared/motion clips to copy")
    folder = tmp_path / "motion"
    shutil.copytree(SHIPPED / "deepmimic_pybullet", folder / "deepmimic_pybullet")
    monkeypatch.setenv("PLEAT_MOTION_DIR", str(folder))
    monkeypatch.setattr(split, "_warned", set())
    from pleat.train import sources
    monkeypatch.setattr(sources, "_CLIP_CACHE", {})
    return folder


GITHUB = [n for n in split.TRAINING + split.VALIDATION if n.startswith("deepmimic_github/")]


def test_the_split_names_what_is_missing(motion_dir, capsys):
    assert split.missing() == GITHUB and len(GITHUB) == 11
    from pleat.motion.cli import main
    assert main(["list"]) == 0
    rows = [line.split() for line in capsys.readouterr().out.splitlines()]
    gone = [r[0] for r in rows if "MISSING" in r]
    assert gone == GITHUB
    assert {r[0] for r in rows if "MISSING" not in r} == {n for n in split.TRAINING + split.VALIDATION
                                                          if n.startswith("deepmimic_pybullet/")}


def test_training_uses_the_rest_and_warns_once(motion_dir, capsys):
    from pleat.train import sources
    train = split.available("training")
    assert train == [n for n in split.TRAINING if not n.startswith("deepmimic_github/")]
    assert split.available("validation") == [n for n in split.VALIDATION if not n.startswith("deepmimic_github/")]
    clips = sources.clips("train", 30.0, count_limit=2)
    assert [c.name for c in clips] == train[:2]
    warnings = [line for line in capsys.readouterr().err.splitlines() if "warning" in line]
    assert len(warnings) == 1 and all(n in warnings[0] for n in GITHUB), warnings
    # a split with none of its clips there is an error, not an empty run
    for n in split.VALIDATION:
        for f in motion_dir.glob(f"{n}.*"):
            f.unlink()
    with pytest.raises(InputError, match="none of the 8 validation clips"):
        split.available("validation")
    assert split.available("validation", required=False) == []


# ---- pleat-train simsup with no clips at all -------------------------------------------------------------------------
@pytest.fixture
def user_sim(tmp_path, monkeypatch):
    """An empty motion folder, and a 12-frame user simulation on a tiny T-shirt: the garment skinned onto a motion of
    the body's own skeleton (a BVH) plus a small sway, as a PC2 cache."""
    pytest.importorskip("torch")
    from pleat.garment import make_garment
    from pleat.motion.bvh_export import write_bvh
    from pleat.motion.clip import identity_clip
    from pleat.rotations import axis_angle_to_matrix, matrix_to_quat
    from pleat.train import core, pointcache, simdata
    empty = tmp_path / "no_motion"
    empty.mkdir()
    monkeypatch.setenv("PLEAT_MOTION_DIR", str(empty))
    monkeypatch.setattr(split, "_warned", set())
    cfg = core.load_config("tiny", None, {})
    body = core.sources.body(cfg["body"])
    make_garment("tshirt", vertices=cfg["garment_vertices"], body=body).save(tmp_path / "shirt.npz")
    setup = core.Setup(cfg, str(tmp_path / "shirt.npz"), "cpu")
    T = 12
    clip = identity_clip(T, 30.0, "sway", tuple(body.joint_names))
    aa = np.zeros((T, 3))
    aa[:, 2] = 0.3 * np.sin(np.linspace(0, np.pi, T))
    q = clip.local_rotations.copy()
    q[:, list(body.joint_names).index("left_shoulder")] = matrix_to_quat(axis_angle_to_matrix(aa))
    clip.local_rotations = q
    clip.root_translation[:, 2] = np.linspace(0.0, 0.4, T)
    write_bvh(tmp_path / "sway.bvh", clip, body)
    beta = np.zeros(setup.B)
    _, _, lbs = pointcache._skinned(setup, simdata.joint_matrices(setup, clip, beta), beta)
    sway = 0.004 * np.sin(np.linspace(0, 2 * np.pi, T))[:, None, None] * np.array([1.0, 0.0, 0.0])
    pointcache.write_pc2(tmp_path / "sway.pc2", (lbs + sway).astype(np.float32))
    return tmp_path


def _train(args, capsys):
    from pleat.train.cli import main
    status = main(["simsup", "--preset", "tiny", "--quiet", "--set", "simsup.iterations=2",
                   "--set", "simsup.dec_iterations=2", "--set", "simsup.contact_iterations=0"] + args)
    return status, capsys.readouterr()


def _listing(folder):
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(Path(folder).rglob("*")) if p.is_file()}


def test_user_sim_only_needs_no_clips_and_a_bad_user_file_writes_nothing(user_sim, capsys):
    d = user_sim
    good = f"cache={d / 'sway.pc2'},motion={d / 'sway.bvh'}"
    common = ["--garment", str(d / "shirt.npz"), "--cache-dir", str(d / "cache")]
    status, out = _train(common + ["--user-sim", good, "--user-sim-only", "--out", str(d / "run")], capsys)
    assert status == 0, out.err[-2000:]
    summary = json.loads((d / "run" / "simsup_summary.json").read_text())
    assert summary["clips"] == [] and summary["frames"] == 12 and summary["validation"] == []
    assert "verdict: no validation clip was simulated" in out.out
    assert (d / "run" / "shirt.pleat").is_file() or list((d / "run").glob("*.pleat"))
    # a bad user file: checked before the clips (the folder has none) and before anything is written
    (d / "old").mkdir()
    (d / "old" / "notes.txt").write_text("an earlier run's notes")
    before = _listing(d / "old")
    (d / "bad.pc2").write_bytes(b"POINTCACHE2\0" + b"\0" * 4)
    bad = f"cache={d / 'bad.pc2'},motion={d / 'sway.bvh'}"
    for extra in ([], ["--user-sim-only"]):
        for out_dir in (d / "old", d / "new"):
            status, out = _train(common + ["--user-sim", bad, "--out", str(out_dir)] + extra, capsys)
            lines = out.err.strip().splitlines()
            assert status == 1 and len(lines) == 1 and "bad.pc2" in lines[0], out.err
        assert _listing(d / "old") == before and not (d / "new").exists()
    # without --user-sim-only the split's clips are needed: none there is one line, and nothing is written
    status, out = _train(common + ["--user-sim", good, "--out", str(d / "old")], capsys)
    lines = out.err.strip().splitlines()
    assert status == 1 and "none of the 23 training clips" in lines[-1], out.err
    assert _listing(d / "old") == before
