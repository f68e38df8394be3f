"""pleat.motion: real DeepMimic clips, retargeting onto the body, augmentation, split, and the BVH / ASF-AMC /
AMASS loaders on small synthetic files."""
import numpy as np
import pytest

from pleat.motion import concatenate, load_clip
from pleat.motion import split as split_mod
from pleat.motion.clip import Clip
from pleat.motion.loaders import list_clips, load_amass, load_asf_amc, load_bvh, motion_dirs
from pleat.motion.retarget import lowest_point_heights
from synthetic_asf import asf_text


def _motion_dir():
    for d in motion_dirs():
        if d.is_dir():
            return d
    return None


needs_clips = pytest.mark.skipif(_motion_dir() is None, reason="no motion folder (run scripts/fetch-motion.sh)")
# fetch-motion.sh gets the 20 pybullet clips from PyPI; the 11 DeepMimic GitHub clips need GitHub (absent on some
# machines), so tests of those clips, and of the full set, need that folder.
needs_github_clips = pytest.mark.skipif(_motion_dir() is None or not (_motion_dir() / "deepmimic_github").is_dir(),
                                        reason="the DeepMimic GitHub clips are not present (GitHub unreachable)")


@pytest.fixture(scope="module")
def walk(body):
    return load_clip("deepmimic_pybullet/humanoid3d_walk", body)


def _unit(q):
    return np.allclose(np.linalg.norm(q, axis=-1), 1, atol=1e-6)


@needs_clips
@pytest.mark.parametrize("name,frames,fps", [("deepmimic_pybullet/humanoid3d_walk", 39, 30),
                                             ("deepmimic_pybullet/humanoid3d_backflip", 29, 16),
                                             pytest.param("deepmimic_github/humanoid3d_jog", 26, 30,
                                                          marks=needs_github_clips),
                                             ("deepmimic_pybullet/walker/turn_left0", 38, 30)])
def test_deepmimic_clips_load(body, name, frames, fps):
    clip = load_clip(name, body)
    assert clip.num_frames == frames and abs(clip.fps - fps) < 0.05
    assert np.all(np.isfinite(clip.local_rotations)) and np.all(np.isfinite(clip.root_translation))
    assert _unit(clip.local_rotations) and _unit(clip.root_rotation)


@needs_clips
@needs_github_clips
def test_every_listed_clip_is_in_the_split_and_the_split_has_no_overlap():
    names = set(list_clips())
    assert len(names) == 31
    assert not set(split_mod.TRAINING) & set(split_mod.VALIDATION)
    assert names == set(split_mod.TRAINING) | set(split_mod.VALIDATION)
    assert any("long_walk" in n for n in split_mod.VALIDATION) and any("long_walk" in n for n in split_mod.TRAINING)


@needs_clips
def test_retargeted_walk_keeps_feet_on_the_ground_and_moves_forward(body, walk):
    J = walk.joint_positions(body)
    lowest = lowest_point_heights(walk, body, vertex_stride=1)
    assert np.abs(lowest).max() < 0.03, "some part of a foot touches y = 0 in every frame"
    feet = J[:, [7, 8], 1].min(axis=1)
    assert feet.max() < 0.2
    pelvis = J[:, 0]
    assert 0.75 < pelvis[:, 1].mean() < 1.1
    step = np.diff(pelvis[:, 2])
    assert pelvis[-1, 2] - pelvis[0, 2] > 1.0 and np.all(step > 0), "walks forward along +Z"
    assert np.abs(pelvis[:, 0]).max() < 0.1
    # upright and facing the walking direction
    assert np.all(J[:, 15, 1] > J[:, 0, 1] + 0.5)
    assert np.abs(walk.heading()).max() < 0.4


@needs_clips
def test_a_deepmimic_standing_frame_stands_on_the_body(body, tmp_path):
    """All DeepMimic joint rotations identity = its rest pose: upright, arms hanging down."""
    frame = [1 / 30, 0, 0.85, 0, 1, 0, 0, 0] + [1, 0, 0, 0] * 2 + ([1, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0]) * 2
    assert len(frame) == 44
    (tmp_path / "stand.txt").write_text('{"Loop": "none", "Frames": [%s]}' % ",".join([str(frame)] * 3))
    clip = load_clip(tmp_path / "stand.txt", body)
    J = clip.joint_positions(body)[0]
    names = body.joint_names
    j = {n: J[i] for i, n in enumerate(names)}
    for side in ("left", "right"):
        assert j[f"{side}_shoulder"][1] - j[f"{side}_wrist"][1] > 0.4, "arms hang down"
        assert abs(j[f"{side}_wrist"][0]) < abs(j[f"{side}_shoulder"][0]) + 0.1
        assert j[f"{side}_hip"][1] - j[f"{side}_ankle"][1] > 0.7, "legs straight down"
    assert j["head"][1] > j["pelvis"][1] + 0.5
    assert j["left_hip"][0] > j["right_hip"][0], "DeepMimic faces +X: turned to face +Z"


@needs_clips
def test_mirroring_twice_is_identity_and_mirroring_swaps_sides(body, walk):
    m = walk.mirrored()
    mm = m.mirrored()
    assert mm.name == walk.name
    assert np.allclose(mm.local_rotations, walk.local_rotations) and np.allclose(mm.root_translation,
                                                                                 walk.root_translation)
    Jw, Jm = walk.joint_positions(body), m.joint_positions(body)
    li, ri = body.joint_index("left_ankle"), body.joint_index("right_ankle")
    # the mirrored left ankle follows the original right ankle reflected through x = 0
    assert np.abs(Jm[:, li] - Jw[:, ri] * np.array([-1, 1, 1])).max() < 0.03


@needs_clips
def test_collar_share_moves_the_clavicle_and_keeps_the_arm(body, walk):
    """Clip.with_collar_share (the "collar" training variant): collar · shoulder is the clip's own product, the collar
    turns by the share of the shoulder's angle, and the shoulder joint moves with it."""
    from pleat.rotations import quat_multiply, quat_to_matrix
    out = walk.with_collar_share(0.25)
    names = list(walk.joint_names)
    for side in ("left", "right"):
        c, sh = names.index(f"{side}_collar"), names.index(f"{side}_shoulder")
        before = quat_to_matrix(quat_multiply(walk.local_rotations[:, c], walk.local_rotations[:, sh]))
        after = quat_to_matrix(quat_multiply(out.local_rotations[:, c], out.local_rotations[:, sh]))
        np.testing.assert_allclose(after, before, atol=1e-9)
        angle = lambda q: 2 * np.arccos(np.clip(np.abs(q[..., 3]), 0, 1))
        moving = angle(walk.local_rotations[:, sh]) > 0.1
        assert moving.any()
        np.testing.assert_allclose(angle(out.local_rotations[moving, c]),
                                   0.25 * angle(walk.local_rotations[moving, sh]), atol=1e-6)
    moved = np.linalg.norm(out.joint_positions(body)[:, names.index("left_shoulder")] -
                           walk.joint_positions(body)[:, names.index("left_shoulder")], axis=-1)
    assert moved.max() > 0.005                      # metres: the shoulder rides on the clavicle
    np.testing.assert_array_equal(out.joint_positions(body)[:, names.index("neck")],
                                  walk.joint_positions(body)[:, names.index("neck")])


@needs_clips
def test_frames_at_takes_every_pose_array_in_the_given_order(walk):
    """Clip.frames_at, which every cut, loop and hold goes through: the rotations, the root's path and its turn at the
    same frames, in the order given (repeats allowed), same fps and joints; the name only when one is given."""
    idx = np.array([3, 1, 1, walk.num_frames - 1, 0])
    out = walk.frames_at(idx)
    for arr, src in ((out.local_rotations, walk.local_rotations), (out.root_translation, walk.root_translation),
                     (out.root_rotation, walk.root_rotation)):
        np.testing.assert_array_equal(arr, src[idx])
    assert (out.name, out.fps, out.joint_names) == (walk.name, walk.fps, walk.joint_names)
    cut = walk.frames_at(slice(2, 7), name="cut")
    assert cut.name == "cut" and cut.num_frames == 5
    np.testing.assert_array_equal(cut.root_translation, walk.root_translation[2:7])


@needs_clips
@pytest.mark.parametrize("move,hold", [(12, 8), (100, 5)])
def test_holds_play_every_frame_in_order_and_stop_dead_after_each_piece(walk, move, hold):
    """Clip.with_holds (the "stop" training variant): the clip's own frames in order, each piece of `move` frames (at
    most half the clip) followed by `hold` copies of its last frame, root included, so the body stops dead."""
    from pleat.train import simdata
    out = walk.with_holds(move, hold)
    T, piece = walk.num_frames, min(move, walk.num_frames // 2)
    pieces = -(-T // piece)
    assert pieces >= 2 and out.num_frames == T + pieces * hold
    moving = np.ones(out.num_frames, bool)
    for k in range(pieces):
        end = min((k + 1) * piece, T)               # frames [k·piece, end) of the clip, then the hold
        at = end + k * hold
        np.testing.assert_array_equal(out.local_rotations[at - (end - k * piece):at],
                                      walk.local_rotations[k * piece:end])
        for arr, src in ((out.local_rotations, walk.local_rotations), (out.root_translation, walk.root_translation),
                         (out.root_rotation, walk.root_rotation)):
            np.testing.assert_array_equal(arr[at:at + hold], np.repeat(src[end - 1][None], hold, 0))
        moving[at:at + hold] = False
    np.testing.assert_array_equal(out.local_rotations[moving], walk.local_rotations)
    assert simdata.variant_clip(walk, "stop").num_frames > walk.num_frames


def _turn(a, b):
    """Angle (rad) of the rotation between unit quaternions a and b, per element."""
    return 2 * np.arccos(np.clip(np.abs(np.sum(a * b, axis=-1)), 0.0, 1.0))


def _root_unchanged(a, b):
    np.testing.assert_array_equal(a.root_translation, b.root_translation)
    np.testing.assert_array_equal(a.root_rotation, b.root_rotation)
    np.testing.assert_array_equal(a.local_rotations[:, 0], b.local_rotations[:, 0])     # the pelvis's R_0


@needs_clips
@pytest.mark.parametrize("other", ["humanoid3d_jump", "humanoid3d_cartwheel"])
@pytest.mark.parametrize("first_is_walk", [True, False])
def test_blend_plays_one_clip_into_another_without_a_jump_at_the_seam(body, walk, other, first_is_walk):
    """The "blend" training variant: clip a as it is up to the cross-fade, then b's own poses (its root path turned
    and moved to carry on from a's), and no joint turns further between two frames of the seam than the two clips
    ever turn between two of their own frames."""
    from pleat.train import simdata
    b = load_clip(f"deepmimic_pybullet/{other}", body).resample(walk.fps)
    a, b = (walk, b) if first_is_walk else (b, walk)
    out = simdata.variant_clip(a, "blend", b)
    first, end = simdata.blend_seam(a, b)
    n = end - first
    assert end == a.num_frames and out.num_frames == a.num_frames + b.num_frames - n and n > 1
    for arr, src in ((out.local_rotations, a.local_rotations), (out.root_translation, a.root_translation),
                     (out.root_rotation, a.root_rotation)):
        np.testing.assert_array_equal(arr[:first], src[:first])
    np.testing.assert_array_equal(out.local_rotations[end:], b.local_rotations[n:])
    np.testing.assert_allclose(np.linalg.norm(np.diff(out.root_translation[end:], axis=0), axis=1),
                               np.linalg.norm(np.diff(b.root_translation[n:], axis=0), axis=1), atol=1e-9)
    own = max(_turn(c.local_rotations[1:], c.local_rotations[:-1]).max() for c in (a, b))
    seam = out.local_rotations[first - 1:end + 1]
    assert _turn(seam[1:], seam[:-1]).max() <= own + 1e-9
    with pytest.raises(ValueError, match="blends into"):
        simdata.variant_clip(a, "blend")


def test_pose_noise_is_smooth_bounded_seeded_and_leaves_the_root_alone():
    """Clip.with_pose_noise with limits that never bind: every joint but the pelvis turned by a slowly wandering
    offset of at most the amplitude (and of about it somewhere), whose second differences are a small part of it;
    the same seed gives the same clip, another seed another."""
    from pleat.motion.clip import identity_clip
    rest = identity_clip(150, fps=30.0)
    amp = 0.1
    wide = (np.full((24, 3), -np.pi), np.full((24, 3), np.pi))
    out = rest.with_pose_noise(amp, seed=4, limits=wide)
    _root_unchanged(out, rest)
    turn = _turn(out.local_rotations, rest.local_rotations)
    assert turn.max() <= amp + 1e-9 and (turn[:, 1:].max(axis=0) > 0.5 * amp).all()
    r = out.joint_rotation_vectors()
    assert np.abs(np.diff(r, 2, axis=0)).max() < 0.1 * amp
    np.testing.assert_array_equal(rest.with_pose_noise(amp, seed=4, limits=wide).local_rotations, out.local_rotations)
    assert np.abs(rest.with_pose_noise(amp, seed=5, limits=wide).local_rotations - out.local_rotations).max() > 0.01


@needs_clips
def test_pose_noise_stays_within_the_clips_own_joint_ranges(walk):
    """Clip.with_pose_noise's default limits (the clip's range per joint and axis, widened by half the amplitude) and
    the "noise" training variant: within the limits, at most the amplitude from the clip's pose, the root as it was,
    no more jerk than the clip's own plus a small part of the amplitude, and the same clip on every call (the seed is
    the clip's name)."""
    from dataclasses import replace

    from pleat.train import simdata
    amp = simdata.NOISE_AMPLITUDE_RAD
    out = simdata.variant_clip(walk, "noise")
    np.testing.assert_array_equal(
        out.local_rotations, walk.with_pose_noise(amp, simdata.noise_seed(walk.name)).local_rotations)
    _root_unchanged(out, walk)
    lo, hi = walk.joint_rotation_range(amp / 2)
    r, r0 = out.joint_rotation_vectors(), walk.joint_rotation_vectors()
    assert (r >= lo - 1e-9).all() and (r <= hi + 1e-9).all()
    turn = _turn(out.local_rotations, walk.local_rotations)
    assert turn.max() <= amp + 1e-9 and turn.max() > 0.5 * amp
    jerk = np.abs(np.diff(r, 2, axis=0)).max(axis=(0, 2))
    assert (jerk <= np.abs(np.diff(r0, 2, axis=0)).max(axis=(0, 2)) + 0.2 * amp).all()
    np.testing.assert_array_equal(simdata.variant_clip(walk, "noise").local_rotations, out.local_rotations)
    renamed = simdata.variant_clip(replace(walk, name="another"), "noise")
    assert np.abs(renamed.local_rotations - out.local_rotations).max() > 0.01


@needs_clips
@pytest.mark.parametrize("fps", [30, 60])
def test_resampling_preserves_duration_and_pose(walk, fps):
    r = walk.resample(fps)
    assert abs(r.duration - walk.duration) <= 0.5 / fps
    assert r.fps == fps and _unit(r.local_rotations)
    back = r.resample(walk.fps)
    assert back.num_frames == walk.num_frames
    dots = np.abs(np.sum(back.local_rotations * walk.local_rotations, axis=-1))
    assert dots.min() > 0.995


@needs_clips
def test_time_scaling_concatenation_and_root_path(body, walk):
    fast = walk.time_scaled(2.0)
    assert abs(fast.duration - walk.duration / 2) < 1 / walk.fps
    assert np.allclose(fast.root_translation[-1], walk.root_translation[-1], atol=1e-6)
    both = concatenate(walk, walk.mirrored(), blend_s=0.2)
    n = int(round(0.2 * walk.fps))
    assert both.num_frames == 2 * walk.num_frames - n
    jumps = np.linalg.norm(np.diff(both.root_translation, axis=0), axis=1)
    assert jumps.max() < 3 * np.linalg.norm(np.diff(walk.root_translation, axis=0), axis=1).max()
    assert both.root_translation[-1, 2] > walk.root_translation[-1, 2] + 0.8, "keeps walking forward"
    turned = walk.with_root_path(yaw_offset=np.pi / 2)
    d = turned.root_translation[-1] - turned.root_translation[0]
    assert d[0] > 1.0 and abs(d[2]) < 0.15, "a quarter turn sends the walk along +X"
    curve = walk.with_root_path(turn_rate=0.5)
    dh = np.unwrap(curve.heading()) - np.unwrap(walk.heading())
    assert abs(dh[-1] - 0.5 * walk.duration) < 1e-6


def test_clip_save_load_roundtrip(tmp_path):
    rng = np.random.default_rng(0)
    q = rng.normal(size=(5, 24, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    r = np.tile([0, 0, 0, 1.0], (5, 1))
    c = Clip(name="x", fps=30, local_rotations=q, root_translation=rng.normal(size=(5, 3)), root_rotation=r)
    c.save(tmp_path / "c.npz")
    d = Clip.load(tmp_path / "c.npz")
    assert d.name == "x" and d.fps == 30 and np.allclose(d.local_rotations, q, atol=1e-6)


# ---- synthetic BVH / ASF-AMC / AMASS ----------------------------------------------------------------------------
def _chain(name, offset, children="", channels="CHANNELS 3 Zrotation Xrotation Yrotation"):
    return f"JOINT {name}\n{{\nOFFSET {offset}\n{channels}\n{children}\n}}\n"


def _end(offset):
    return f"End Site\n{{\nOFFSET {offset}\n}}\n"


def _bvh_text(knee_x_deg, root_z):
    """A T-pose skeleton in centimetres, Y up, facing +Z (left = +X), CMU-style names."""
    leg = lambda s, x: _chain(f"{s}UpLeg", f"{x} -5 0", _chain(f"{s}Leg", "0 -42 0", _chain(
        f"{s}Foot", "0 -41 0", _chain(f"{s}ToeBase", "0 -5 12", _end("0 0 4")))))
    arm = lambda s, x: _chain(f"{s}Shoulder", f"{x * 3} 20 0", _chain(f"{s}Arm", f"{x * 15} 0 0", _chain(
        f"{s}ForeArm", f"{x * 28} 0 0", _chain(f"{s}Hand", f"{x * 25} 0 0", _end(f"{x * 8} 0 0")))))
    spine = _chain("Spine", "0 10 0", _chain("Spine1", "0 15 0", _chain("Neck", "0 25 0", _chain(
        "Head", "0 10 0", _end("0 15 0"))) + arm("Left", 1) + arm("Right", -1)))
    hierarchy = ("HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation "
                 "Xrotation Yrotation\n" + leg("Left", 9) + leg("Right", -9) + spine + "}\n")
    names = ["Hips", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase", "RightUpLeg", "RightLeg", "RightFoot",
             "RightToeBase", "Spine", "Spine1", "Neck", "Head", "LeftShoulder", "LeftArm", "LeftForeArm", "LeftHand",
             "RightShoulder", "RightArm", "RightForeArm", "RightHand"]
    frames = []
    for kx, z in zip(knee_x_deg, root_z):
        vals = [0, 95, z, 0, 0, 0]
        for n in names[1:]:
            vals += [0, kx if n == "LeftLeg" else 0, 0]
        frames.append(" ".join(str(v) for v in vals))
    return hierarchy + f"MOTION\nFrames: {len(frames)}\nFrame Time: 0.04\n" + "\n".join(frames) + "\n"


def _shin_direction(body, clip, frame, side="left"):
    J = clip.joint_positions(body)[frame]
    d = J[body.joint_index(f"{side}_ankle")] - J[body.joint_index(f"{side}_knee")]
    return d / np.linalg.norm(d)


def test_bvh_loader_retargets_knee_flexion(body, tmp_path):
    (tmp_path / "t.bvh").write_text(_bvh_text([0, 90, 0], [0, 50, 100]))
    clip = load_bvh(tmp_path / "t.bvh", body)
    assert clip.num_frames == 3 and abs(clip.fps - 25) < 1e-9
    assert _unit(clip.local_rotations)
    assert _shin_direction(body, clip, 0)[1] < -0.95, "standing: shin points down"
    # BVH Xrotation +90 at the knee of a character facing +Z swings the shin to point backwards (−Z)
    assert _shin_direction(body, clip, 1) @ np.array([0, 0, -1]) > 0.95
    assert _shin_direction(body, clip, 1, "right")[1] < -0.95
    # root moves 50 cm per frame along +Z; scaled by the leg-length ratio (body legs ≈ 0.87 m vs 0.83 m)
    p = clip.pelvis_positions()
    assert 0.4 < p[1, 2] - p[0, 2] < 0.65 and abs(p[1, 0] - p[0, 0]) < 1e-6


HIERARCHY = ["root lhipjoint rhipjoint lowerback", "lhipjoint lfemur", "lfemur ltibia", "ltibia lfoot",
             "rhipjoint rfemur", "rfemur rtibia", "rtibia rfoot", "lowerback upperback", "upperback thorax",
             "thorax lowerneck lclavicle rclavicle", "lowerneck head", "lclavicle lhumerus", "lhumerus lradius",
             "lradius lwrist", "rclavicle rhumerus", "rhumerus rradius", "rradius rwrist"]
BONES = [("lhipjoint", "1 -0.5 0", 9, "0 0 0"), ("lfemur", "0 -1 0", 42, "0 0 0"), ("ltibia", "0 -1 0", 41, "0 0 90"),
         ("lfoot", "0 0 1", 12, "0 0 0"), ("rhipjoint", "-1 -0.5 0", 9, "0 0 0"), ("rfemur", "0 -1 0", 42, "0 0 0"),
         ("rtibia", "0 -1 0", 41, "0 0 0"), ("rfoot", "0 0 1", 12, "0 0 0"), ("lowerback", "0 1 0", 12, "0 0 0"),
         ("upperback", "0 1 0", 12, "0 0 0"), ("thorax", "0 1 0", 12, "0 0 0"), ("lowerneck", "0 1 0", 10, "0 0 0"),
         ("head", "0 1 0", 15, "0 0 0"), ("lclavicle", "1 0.2 0", 16, "0 0 0"), ("lhumerus", "1 0 0", 28, "0 0 0"),
         ("lradius", "1 0 0", 25, "0 0 0"), ("lwrist", "1 0 0", 8, "0 0 0"), ("rclavicle", "-1 0.2 0", 16, "0 0 0"),
         ("rhumerus", "-1 0 0", 28, "0 0 0"), ("rradius", "-1 0 0", 25, "0 0 0"), ("rwrist", "-1 0 0", 8, "0 0 0")]


def test_asf_amc_loader_uses_the_bone_axes(body, tmp_path):
    (tmp_path / "s.asf").write_text(asf_text(BONES, HIERARCHY))
    frames = []
    for i, ry in enumerate([0, -90]):
        frames.append(f"{i + 1}\nroot 0 90 {i * 30} 0 0 0\n" + "\n".join(
            f"{n} 0 {ry if n == 'ltibia' else 0} 0" for n, *_ in BONES))
    (tmp_path / "s.amc").write_text(":FULLY-SPECIFIED\n:DEGREES\n" + "\n".join(frames) + "\n")
    clip = load_asf_amc(tmp_path / "s.amc", body, fps=60)
    assert clip.num_frames == 2 and clip.fps == 60
    assert _shin_direction(body, clip, 0)[1] < -0.95
    # ltibia's local frame is turned 90° about z, so its ry of −90° is a +90° turn about world +X: knee flexion
    assert _shin_direction(body, clip, 1) @ np.array([0, 0, -1]) > 0.95


def test_amass_loader_maps_smplh_body_joints(body, tmp_path):
    T = 4
    poses = np.zeros((T, 156))
    poses[:, 0] = np.pi / 2          # AMASS stands the Y-up SMPL body up in its Z-up world
    poses[2, 3 * 4] = np.pi / 2      # left knee (SMPL joint 4) flexed 90°
    poses[:, 66:] = 0.3              # hand joints are dropped
    trans = np.zeros((T, 3))
    trans[:, 0] = np.arange(T) * 0.1  # +X in the Z-up world stays +X
    trans[:, 2] = 0.9                 # up
    np.savez(tmp_path / "amass.npz", poses=poses, trans=trans, mocap_framerate=np.array(120.0), betas=np.zeros(16))
    clip = load_amass(tmp_path / "amass.npz", body)
    assert clip.num_frames == T and clip.fps == 120
    assert np.allclose(clip.local_rotations[:, [22, 23]], [0, 0, 0, 1])
    J = clip.joint_positions(body)
    assert np.all(J[:, 15, 1] > J[:, 0, 1] + 0.4), "upright in our Y-up frame"
    assert np.allclose(np.diff(clip.pelvis_positions()[:, 0]), 0.1)
    assert _shin_direction(body, clip, 2) @ np.array([0, 0, -1]) > 0.95
    # SMPL's rest is a T-pose: an identity arm rotation gives a horizontal arm on our A-pose body
    arm = J[0, body.joint_index("left_elbow")] - J[0, body.joint_index("left_shoulder")]
    assert abs(arm[1]) < 0.02 * np.linalg.norm(arm) + 0.01 and arm[0] > 0
