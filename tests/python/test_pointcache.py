"""A technical artist's own simulation as training data (pleat.train.pointcache; docs/your-simulation.md): the PC2 layout,
the checks (one line each), and the round trip — a segment simulated by pleat.sim, written as PC2 (cm, Z up) + OBJ
+ BVH, read back — giving the same training sequence as simdata.sequence on the original positions. Then the DCC
kit of `pleat-garment scene` and `pleat-train simsup --user-sim` end to end, printing its verdict. Needs torch (the
training setup) and the motion clips; ~2 min on the shared 2-core machine."""
import json
import struct
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

pytest.importorskip("torch")

from pleat.cli import InputError                                                # noqa: E402
from pleat.garment.meshio import from_pleat_axes, read_obj, to_pleat_axes, write_obj  # noqa: E402
from pleat.motion.bvh_export import write_bvh                                    # noqa: E402
from pleat.train import pointcache as pc                                        # noqa: E402
from pleat.train import simdata                                                 # noqa: E402

CLIP = "deepmimic_pybullet/humanoid3d_walk"
BETA = np.array([1.0, -0.5] + [0.0] * 8)
MATERIAL = np.array([0.3, 30000.0, 50000.0, 1e-4])


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    from pleat.garment import make_garment
    from pleat.train import core
    cfg = core.load_config("tiny", None, {})
    folder = tmp_path_factory.mktemp("garment")
    body = core.sources.body(cfg["body"])
    make_garment("tshirt", vertices=cfg["garment_vertices"], body=body).save(folder / "shirt.npz")
    s = core.Setup(cfg, str(folder / "shirt.npz"), "cpu")
    s.garment_path = folder / "shirt.npz"
    return s


@pytest.fixture(scope="module")
def clip(setup):
    from pleat.motion import MotionFileError, load_clip
    try:
        return load_clip(CLIP, body=setup.body).resample(30.0)
    except MotionFileError as exc:
        pytest.skip(f"no motion clips ({exc})")


@pytest.fixture(scope="module")
def simulated(setup, clip):
    """6 frames of the walk (from frame 5) simulated by the reference simulator at β, material ≠ default."""
    from pleat.garment import Garment
    from pleat.physics.materials import Material
    from pleat.sim.scene import simulate
    seg = simdata.cut(clip, 5, 6)
    g = Garment.load(setup.garment_path)
    pos, _, _ = simulate(g, setup.body, seg, BETA, Material(*MATERIAL), 6, progress=False, keep_body=False)
    return seg, pos


def _sim(**kw):
    kw.setdefault("beta", tuple(BETA))
    kw.setdefault("material", tuple(MATERIAL))
    return pc.UserSim(**kw)


# ---- PC2 and npz ---------------------------------------------------------------------------------------------------
def test_pc2_layout_is_the_documented_one(tmp_path):
    pos = np.arange(2 * 3 * 3, dtype=np.float32).reshape(2, 3, 3) / 7.0
    path = pc.write_pc2(tmp_path / "c.pc2", pos, start_frame=12.0, sample_rate=0.5)
    data = path.read_bytes()
    assert len(data) == 32 + 2 * 3 * 12
    assert struct.unpack_from("<12siiffi", data) == (b"POINTCACHE2\0", 1, 3, 12.0, 0.5, 2)
    assert np.array_equal(np.frombuffer(data[32:], "<f4").reshape(2, 3, 3), pos)     # sample-major, xyz per point
    cache = pc.read_pc2(path)
    assert np.array_equal(cache.positions, pos) and (cache.start_frame, cache.sample_rate) == (12.0, 0.5)
    pc.write_npz_cache(tmp_path / "c.npz", pos, 3.0, 2.0)
    cache = pc.read_cache(tmp_path / "c.npz")
    assert np.array_equal(cache.positions, pos) and (cache.start_frame, cache.sample_rate) == (3.0, 2.0)


def _bad_caches(tmp_path):
    good = pc.write_pc2(tmp_path / "good.pc2", np.zeros((3, 4, 3), np.float32)).read_bytes()
    files = {
        "sig.pc2": (b"POINTCACHE3\0" + good[12:], "not a PC2 file"),
        "version.pc2": (good[:12] + struct.pack("<i", 2) + good[16:], "version 2"),
        "short.pc2": (good[:20], "too short"),
        "truncated.pc2": (good[:-4], "truncated"),
        "trailing.pc2": (good + b"\0\0\0\0", "trailing bytes"),
        "nosamples.pc2": (good[:28] + struct.pack("<i", 0), "no samples"),
        "rate.pc2": (good[:24] + struct.pack("<f", 0.0) + good[28:], "positive number"),
        "points.pc2": (good[:16] + struct.pack("<i", -4) + good[20:], "point count"),
    }
    nan = np.zeros((3, 4, 3), np.float32)
    nan[2, 1, 0] = np.nan
    files["nan.pc2"] = (pc.write_pc2(tmp_path / "n.pc2", nan).read_bytes(), "sample 2, point 1 is not finite")
    for name, (data, _) in files.items():
        (tmp_path / name).write_bytes(data)
    np.savez(tmp_path / "nopos.npz", points=np.zeros((2, 3, 3)))
    np.savez(tmp_path / "shape.npz", positions=np.zeros((2, 3)))
    (tmp_path / "cache.abc").write_bytes(b"x")
    out = {k: v[1] for k, v in files.items()}
    out.update({"nopos.npz": "without 'positions'", "shape.npz": "expected [frames, vertices, 3]",
                "cache.abc": "unknown point cache format", "absent.pc2": "no such point cache"})
    return out


def test_bad_caches_name_the_problem(tmp_path):
    for name, words in _bad_caches(tmp_path).items():
        with pytest.raises(InputError) as got:
            pc.read_cache(tmp_path / name)
            pytest.fail(f"{name} was read")
        assert words in str(got.value) and str(tmp_path / name) in str(got.value), (name, str(got.value))


def test_specs_from_a_manifest_and_key_values(tmp_path):
    (tmp_path / "m.json").write_text(json.dumps({"simulations": [
        {"cache": "a.pc2", "motion": "a.bvh", "garment_obj": "a.obj", "units": "cm", "up": "z", "beta": [1, 2],
         "skip_frames": 20, "motion_start_frame": 1}]}))
    sims = pc.parse_user_sims([str(tmp_path / "m.json"),
                               "cache=/x/b.npz,motion=humanoid3d_walk,beta=0.5:1,material=0.2:23600:44400:4e-5,"
                               "role=validation"])
    a, b = sims
    assert (a.cache, a.motion, a.garment_obj) == tuple(str(tmp_path / f) for f in ("a.pc2", "a.bvh", "a.obj"))
    assert (a.units, a.up, a.beta, a.skip_frames, a.motion_start_frame, a.role) == ("cm", "z", (1.0, 2.0), 20, 1.0,
                                                                                   "train")
    assert (b.motion, b.beta, b.material, b.role) == ("humanoid3d_walk", (0.5, 1.0), (0.2, 23600, 44400, 4e-5),
                                                      "validation")
    for bad, words in (("cache=a.pc2", "needs 'motion'"), ("cache=a.pc2,motion=b.bvh,colour=red", "unknown key"),
                       ("a.pc2", "key=value"), ("cache=a,motion=b,beta=x:y", "beta must be numbers"),
                       ("cache=a,motion=b,role=test", "role 'test'")):
        with pytest.raises(InputError, match=words):
            pc.parse_user_sims([bad])


# ---- the round trip --------------------------------------------------------------------------------------------------
def test_pc2_obj_bvh_round_trip_equals_the_simulated_sequence(tmp_path, setup, simulated):
    """The simulated segment as PC2 (cm, Z up) + OBJ + BVH reads back as the sequence simdata.sequence makes from
    the original positions: X_c rows to rounding, displacement targets to float32 precision (the cache's)."""
    seg, pos = simulated
    ref = simdata.sequence(setup, seg, BETA, MATERIAL, pos)
    pc.write_pc2(tmp_path / "shirt.pc2", from_pleat_axes(pos, "z", "cm").astype(np.float32), 1.0, 1.0)
    write_obj(tmp_path / "shirt.obj", from_pleat_axes(setup.shaped(BETA), "z", "cm"), setup.faces)
    write_bvh(tmp_path / "walk.bvh", seg, setup.body)
    sim = _sim(cache=str(tmp_path / "shirt.pc2"), motion=str(tmp_path / "walk.bvh"),
               garment_obj=str(tmp_path / "shirt.obj"), units="cm", up="z")
    from pleat.motion import load_clip
    back = load_clip(tmp_path / "walk.bvh", body=setup.body)          # the loaders read the Pleat skeleton exactly
    assert np.abs(back.root_translation - seg.root_translation).max() < 1e-12
    assert np.abs(back.joint_positions(setup.body) - seg.joint_positions(setup.body)).max() < 1e-12
    got, info = pc.load_user_sim(setup, sim, 30.0)
    assert got["static"].shape == ref["static"].shape and got["disp"].shape == ref["disp"].shape == pos.shape
    assert np.abs(got["static"] - ref["static"]).max() < 1e-9
    assert np.abs(got["disp"] - ref["disp"]).max() < 3e-7                    # float32 in cm: ~1e-7 m
    assert np.abs(ref["disp"]).max() > 1e-3                                   # the simulation is not LBS
    assert info["frames"] == 6 and info["obj_residual_mm"] < 1e-3 and info["mean_from_lbs_mm"] > 1.0
    # npz in metres holds the simulator's float32 positions exactly: the same targets to rounding
    pc.write_npz_cache(tmp_path / "shirt.npz", pos)
    got, _ = pc.load_user_sim(setup, replace(sim, cache=str(tmp_path / "shirt.npz"), units="m", up="y",
                                             garment_obj=None), 30.0)
    assert np.abs(got["disp"] - ref["disp"]).max() < 1e-12 and np.abs(got["static"] - ref["static"]).max() < 1e-9


def test_frame_offsets_skip_sample_rate_and_resampling(tmp_path, setup, simulated):
    seg, pos = simulated
    write_bvh(tmp_path / "walk.bvh", seg, setup.body)
    # samples at scene frames 12..17, the motion from scene frame 12, the first two samples skipped: frames 2..5
    pc.write_npz_cache(tmp_path / "late.npz", pos, start_frame=12.0)
    got, _ = pc.load_user_sim(setup, _sim(cache=str(tmp_path / "late.npz"), motion=str(tmp_path / "walk.bvh"),
                                          motion_start_frame=12.0, skip_frames=2), 30.0)
    ref = simdata.sequence(setup, simdata.cut(seg, 2, 4), BETA, MATERIAL, pos[2:])
    assert np.abs(got["disp"] - ref["disp"]).max() < 1e-12 and np.abs(got["static"] - ref["static"]).max() < 1e-9
    # samples at scene frames 11..14, the motion from scene frame 10: motion frames 1..4
    pc.write_npz_cache(tmp_path / "mid.npz", pos[1:5], start_frame=11.0)
    got, _ = pc.load_user_sim(setup, _sim(cache=str(tmp_path / "mid.npz"), motion=str(tmp_path / "walk.bvh"),
                                          motion_start_frame=10.0), 30.0)
    ref = simdata.sequence(setup, simdata.cut(seg, 1, 4), BETA, MATERIAL, pos[1:5])
    assert np.abs(got["disp"] - ref["disp"]).max() < 1e-12 and np.abs(got["static"] - ref["static"]).max() < 1e-9
    # the motion at 60 fps: a cache of every frame (60 fps) is resampled to 30; one of every other frame
    # (sample rate 2) is at 30 already; both give the 30 fps sequence
    seg60 = seg.resample(60.0)
    write_bvh(tmp_path / "walk60.bvh", seg60, setup.body)
    pos60 = np.empty((11,) + pos.shape[1:], np.float32)
    pos60[0::2] = pos
    pos60[1::2] = 0.5 * (pos[:-1] + pos[1:])
    pc.write_npz_cache(tmp_path / "c60.npz", pos60)
    pc.write_npz_cache(tmp_path / "c30.npz", pos, sample_rate=2.0)
    ref = simdata.sequence(setup, seg, BETA, MATERIAL, pos)
    for name in ("c60.npz", "c30.npz"):
        got, info = pc.load_user_sim(setup, _sim(cache=str(tmp_path / name), motion=str(tmp_path / "walk60.bvh")),
                                     30.0)
        assert info["cache_fps"] == (60.0 if name == "c60.npz" else 30.0) and info["frames"] == 6
        assert np.abs(got["disp"] - ref["disp"]).max() < 1e-9, name
        assert np.abs(got["static"] - ref["static"]).max() < 1e-6, name


def test_checks_name_the_problem(tmp_path, setup, simulated):
    seg, pos = simulated
    write_bvh(tmp_path / "walk.bvh", seg, setup.body)
    bvh = str(tmp_path / "walk.bvh")
    pc.write_pc2(tmp_path / "ok.pc2", from_pleat_axes(pos, "z", "cm").astype(np.float32), 1.0, 1.0)
    pc.write_pc2(tmp_path / "more.pc2", np.concatenate([pos, pos[:, :1]], 1), 1.0, 1.0)
    pc.write_pc2(tmp_path / "long.pc2", np.concatenate([pos, pos[-2:]]), 1.0, 1.0)
    rest = from_pleat_axes(setup.shaped(BETA), "z", "cm")
    perm = np.random.default_rng(0).permutation(setup.N)
    write_obj(tmp_path / "reordered.obj", rest[perm], np.argsort(perm)[setup.faces])
    write_obj(tmp_path / "fewer.obj", rest[:-1], setup.faces[np.all(setup.faces < setup.N - 1, 1)])
    ok = dict(cache=str(tmp_path / "ok.pc2"), motion=bvh, units="cm", up="z")
    cases = [
        (dict(ok, cache=str(tmp_path / "more.pc2"), units="m", up="y"), f"has {setup.N + 1} points; the garment"),
        (dict(ok, cache=str(tmp_path / "long.pc2"), units="m", up="y"), "frame count mismatch"),
        (dict(ok, motion_start_frame=3.0), "before the motion's first frame"),
        (dict(ok, units="m"), "with up=z, units=cm it would be"),
        (dict(ok, up="y"), "with up=z, units=cm it would be"),
        (dict(ok, garment_obj=str(tmp_path / "reordered.obj")), "another vertex order"),
        (dict(ok, garment_obj=str(tmp_path / "fewer.obj")), f"has {setup.N - 1} vertices; the garment has"),
        (dict(ok, skip_frames=5), "leaves fewer than 2"),
        (dict(ok, beta=(0.0,) * 11), "beta has 11 values"),
        (dict(ok, material=(0.2, 1.0, 44400.0, 4e-5)), "outside the asset's ranges"),
    ]
    for kw, words in cases:
        with pytest.raises(InputError) as got:
            pc.load_user_sim(setup, _sim(**kw), 30.0)
        assert words in str(got.value), (kw, str(got.value))


# ---- the DCC kit and pleat-train simsup --user-sim ------------------------------------------------------------------
def test_scene_kit_and_simsup_with_a_user_simulation(tmp_path, setup, clip):
    """`pleat-garment scene` writes the body, garment and motion (cm, Z up); a stand-in for the DCC tool simulates
    garment_start.obj on that body; `pleat-train simsup --user-sim kit/user_sim.json` (plus one simulated segment)
    trains on it and prints its verdict; `--user-sim-only` with a user validation simulation needs no simulator."""
    from pleat.garment import Garment
    from pleat.sim.scene import simulate
    from pleat.garment.scene import kit_clip
    kit = tmp_path / "kit"
    run = subprocess.run([sys.executable, "-m", "pleat.garment.cli", "scene", "--out", str(kit), "--garment",
                          str(setup.garment_path), "--motion", CLIP, "--frames", "10", "--units", "cm", "--up", "z"],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    manifest = json.loads((kit / "user_sim.json").read_text())["simulations"][0]
    want, lead = kit_clip(simdata.cut(clip, 0, 10))
    assert manifest["skip_frames"] == lead == 20 and manifest["cache"] == "garment_sim.pc2"
    body_cache = pc.read_pc2(kit / "body.pc2")
    assert body_cache.samples == 30 and body_cache.start_frame == 1.0
    posed = setup.body.skin(want.local_matrices()[[0, lead]], want.root_translation[[0, lead]],
                            want.root_matrices()[[0, lead]])
    assert np.abs(to_pleat_axes(body_cache.positions[[0, lead]], "z", "cm") - posed).max() < 1e-5
    motion = pc.load_motion(str(kit / "motion.bvh"), setup.body)
    assert motion.num_frames == 30 and np.allclose(motion.root_translation, want.root_translation, atol=1e-9)
    g = Garment.load(setup.garment_path)
    assert np.allclose(to_pleat_axes(read_obj(kit / "garment.obj").vertices, "z", "cm"), g.template, atol=1e-6)
    start = to_pleat_axes(read_obj(kit / "garment_start.obj").vertices, "z", "cm")
    assert pc._rigid_residual(start, g.template.astype(np.float64)) < 1e-6   # rest shape, carried rigidly
    # the DCC tool's job, done by the reference simulator: start from garment_start.obj, follow body.pc2
    pos, _, _ = simulate(g, setup.body, motion, None, None, None, progress=False, keep_body=False,
                         lead_in_frames=0, hold_frames=0)
    pc.write_pc2(kit / "garment_sim.pc2", from_pleat_axes(pos, "z", "cm").astype(np.float32), 1.0, 1.0)
    common = [sys.executable, "-m", "pleat.train.cli", "simsup", "--preset", "tiny", "--garment",
              str(setup.garment_path), "--user-sim", str(kit / "user_sim.json"), "--quiet"]
    run = subprocess.run(common + ["--out", str(tmp_path / "run"), "--cache-dir", str(tmp_path / "cache"),
                                   "--set", "simsup.max_segments=1", "--set", "simsup.validation_frames=4"],
                         capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr[-3000:]
    verdicts = [line for line in run.stdout.splitlines() if line.startswith("verdict: ")]
    assert len(verdicts) == 1 and "than LBS-only on 1 validation clips" in verdicts[0], run.stdout
    summary = json.loads((tmp_path / "run" / "simsup_summary.json").read_text())
    assert summary["segments"] == 2 and summary["frames"] == 12 + 10       # one simulated segment + the user's
    assert [u["name"] for u in summary["user_simulations"]] == [manifest["name"]]
    assert (tmp_path / "run" / f"{setup.name}.pleat").is_file()
    val = f"cache={kit / 'garment_sim.pc2'},motion={kit / 'motion.bvh'},units=cm,up=z,skip_frames=20," \
          "role=validation,name=kit_walk"
    run = subprocess.run(common + ["--user-sim", val, "--user-sim-only", "--out", str(tmp_path / "only"),
                                   "--cache-dir", str(tmp_path / "empty_cache")],
                         capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr[-3000:]
    assert "verdict: " in run.stdout and "kit_walk" in json.dumps(
        json.loads((tmp_path / "only" / "simsup_summary.json").read_text())["validation"])
    assert not (tmp_path / "empty_cache").exists() or not any((tmp_path / "empty_cache").iterdir())
    bad = subprocess.run(common[:-3] + ["--user-sim", f"cache={kit / 'body.pc2'},motion={kit / 'motion.bvh'}",
                                        "--out", str(tmp_path / "bad"), "--quiet"],
                         capture_output=True, text=True, timeout=900)
    lines = bad.stderr.strip().splitlines()
    assert bad.returncode == 1 and len(lines) == 1 and "the cache is not of this garment" in lines[0], bad.stderr
