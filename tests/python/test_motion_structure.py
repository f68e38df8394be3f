"""Retargeting by structure and the retargeting check: six naming schemes (Mixamo, Biovision, CMU, 3ds Max Biped,
Unreal's mannequin, the body's own names) in three rest poses map onto the body with the source's bone directions,
and a wrong match (Biovision's names read through the Mixamo table) is reported, refused with --strict."""
import json

import numpy as np
import pytest

from motion_schemes import SCHEMES, bvh_text, expected_map, with_floor_root
from pleat.motion import cli as motion_cli
from pleat.motion.check import BONE_LIMIT_DEG, INSIDE_LIMIT
from pleat.motion.loaders import MotionFileError, load_clip

WRONG_BIOVISION = {"LeftShoulder": "left_collar", "RightShoulder": "right_collar"}


@pytest.mark.parametrize("pose", ["A", "T", "down"])
@pytest.mark.parametrize("scheme", SCHEMES)
def test_each_scheme_maps_by_structure_with_the_sources_bone_directions(body, tmp_path, scheme, pose):
    path = tmp_path / f"{scheme}.bvh"
    path.write_text(bvh_text(body, scheme, pose))
    clip, match, check = load_clip(path, body, with_check=True, check=False)
    want = expected_map(body, scheme)
    assert {k: match.mapping.get(k) for k in want} == want
    assert check.problems == []
    if not (scheme == "body" and pose == "A"):      # the body's own skeleton is read exactly, not retargeted
        assert check.worst_bone[1] < 1.0 < BONE_LIMIT_DEG and len(check.bone_deg) >= 12
    # the motion keeps the forearms and hands out of the body, in every rest pose
    assert check.inside_fraction <= 0.01


@pytest.mark.parametrize("pose", ["A", "T", "down"])
def test_biovision_names_through_the_mixamo_table_are_reported(body, tmp_path, pose, capsys):
    # with the arms hanging in the source's rest too: the collar that the match swings down along the upper arm is
    # compared with the source's clavicle, where the body's own rest holds it, not where the match posed it
    path = tmp_path / "bio.bvh"
    path.write_text(bvh_text(body, "biovision", pose))
    jmap = tmp_path / "wrong.json"
    jmap.write_text(json.dumps(WRONG_BIOVISION))
    _, match, check = load_clip(path, body, joint_map_file=jmap, with_check=True, check=False)
    assert match.mapping["left_collar"] == "LeftShoulder" and "left_shoulder" not in match.mapping
    assert check.worst_bone[1] > BONE_LIMIT_DEG and check.problems
    assert check.bone_source["left_collar→left_shoulder"] == "LeftCollar→LeftShoulder"
    # every loader warns in one line; --strict refuses in one error line and writes nothing
    load_clip(path, body, joint_map_file=jmap)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"warning: {path}: bone directions")
    out = tmp_path / "o.npz"
    assert motion_cli.main(["convert", str(path), "--joint-map", str(jmap), "--out", str(out), "--strict"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "retargeting check failed (--strict)" in err[0] and not out.exists()


def test_a_wrong_map_that_puts_the_forearms_through_the_chest_is_reported_by_the_self_intersection(body, tmp_path,
                                                                                                   capsys):
    # arms hanging in the source's rest: the collar takes the upper arm's rotation and the arm goes into the chest;
    # the bone directions report it too, and this measure must on its own
    path = tmp_path / "bio.bvh"
    path.write_text(bvh_text(body, "biovision", "down"))
    jmap = tmp_path / "wrong.json"
    jmap.write_text(json.dumps(WRONG_BIOVISION))
    _, _, check = load_clip(path, body, joint_map_file=jmap, with_check=True, check=False)
    assert check.inside_fraction > INSIDE_LIMIT and any("inside the body" in p for p in check.problems)
    load_clip(path, body, joint_map_file=jmap)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "forearms and hands inside the body" in err[0]
    with pytest.raises(MotionFileError, match="retargeting check failed"):
        load_clip(path, body, joint_map_file=jmap, strict=True)


def test_the_same_source_matched_right_has_no_forearm_inside_the_body(body, tmp_path):
    path = tmp_path / "bio.bvh"
    path.write_text(bvh_text(body, "biovision", "down"))
    _, _, check = load_clip(path, body, with_check=True, check=False)
    assert check.inside_fraction == 0.0 and check.problems == []


def test_structure_not_names_decides_biovisions_shoulder(body, tmp_path):
    path = tmp_path / "bio.bvh"
    path.write_text(bvh_text(body, "biovision", "T"))
    _, match = load_clip(path, body, with_match=True)
    assert match.mapping["left_collar"] == "LeftCollar" and match.mapping["left_shoulder"] == "LeftShoulder"
    assert match.origin["left_shoulder"] == "structure"     # no table says LeftShoulder is an upper arm
    assert match.origin["left_collar"].startswith("structure; the names say")


def test_joints_prints_the_check_and_writes_a_preview(body, tmp_path, capsys):
    path = tmp_path / "unreal.bvh"
    path.write_text(bvh_text(body, "unreal", "T"))
    png = tmp_path / "preview.png"
    assert motion_cli.main(["joints", str(path), "--out", str(png)]) == 0
    text = capsys.readouterr().out
    assert "left_shoulder   <- upperarm_l  (structure)" in text
    assert "worst bone:" in text and "check: within what the training clips do" in text
    assert png.stat().st_size > 1000
    assert motion_cli.main(["joints", str(path), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["check"]["problems"] == [] and report["check"]["inside_fraction"] <= INSIDE_LIMIT


def test_a_shipped_training_clip_passes_the_check(body):
    pytest.importorskip("scipy")
    from pleat.motion.loaders import motion_dirs
    if not any(d.is_dir() for d in motion_dirs()):
        pytest.skip("no motion folder")
    _, _, check = load_clip("deepmimic_pybullet/humanoid3d_walk", body, with_check=True, check=False)
    assert check.problems == [] and check.worst_bone[1] < 1.0


@pytest.mark.parametrize("pelvis_positions", [False, True])
@pytest.mark.parametrize("scheme", ["unreal", "mixamo"])
def test_a_root_bone_on_the_floor_is_folded_into_the_hips(body, tmp_path, scheme, pelvis_positions):
    """An engine's root bone above the hips (Unreal's `root`, with its IK target bones) is not the pelvis: the
    skeleton is re-rooted at the hips, the match is the plain skeleton's, and the clip is the same motion — whether
    the root carries the path or the pelvis has position channels of its own."""
    plain = tmp_path / "plain.bvh"
    plain.write_text(bvh_text(body, scheme, "T"))
    rooted = tmp_path / "rooted.bvh"
    rooted.write_text(with_floor_root(plain.read_text(), pelvis_positions=pelvis_positions))
    want, _ = load_clip(plain, body, with_match=True, check=False)
    got, match, check = load_clip(rooted, body, with_check=True, check=False)
    assert {k: match.mapping.get(k) for k in expected_map(body, scheme)} == expected_map(body, scheme)
    assert check.problems == [] and check.worst_bone[1] < 1.0
    assert np.allclose(got.root_translation, want.root_translation, atol=1e-6)
    assert np.allclose(np.abs(np.sum(got.local_rotations * want.local_rotations, -1)), 1.0, atol=1e-9)
    assert np.allclose(np.abs(np.sum(got.root_rotation * want.root_rotation, -1)), 1.0, atol=1e-9)


def test_a_root_that_sits_with_the_hips_stays_the_pelvis(body):
    """3ds Max Biped hangs its thighs from `Bip01 Spine`, a few centimetres above `Bip01` (the root): the legs fork
    there, but the root sits with the hips and is the pelvis, as before."""
    from motion_schemes import skeleton
    from pleat.motion.structure import hips_joint
    joints, _ = skeleton(body, "biped", "T")
    parents = [-1 if p is None else p for _, _, p, _ in joints]
    assert hips_joint(parents, np.array([pos for *_, pos in joints])) == 0
    joints, _ = skeleton(body, "unreal", "T")
    parents = [-1 if p is None else p for _, _, p, _ in joints]
    assert hips_joint(parents, np.array([pos for *_, pos in joints])) == 0


@pytest.mark.parametrize("axis", ["+Z", "-X"])
@pytest.mark.parametrize("scheme", ["mixamo", "cmu", "biped", "unreal"])
def test_a_skeleton_standing_along_another_axis_is_turned_upright(body, tmp_path, scheme, axis):
    """A Z-up (or X-up) file read as +Y up has its legs found sideways and left and right swapped, silently: the up
    axis is read from the rest skeleton, and the clip is the +Y-up file's."""
    from motion_schemes import turned
    plain = tmp_path / "plain.bvh"
    plain.write_text(bvh_text(body, scheme, "A"))
    other = tmp_path / "turned.bvh"
    other.write_text(turned(plain.read_text(), axis))
    want = load_clip(plain, body, check=False)
    got, match, check = load_clip(other, body, with_check=True, check=False)
    assert {k: match.mapping.get(k) for k in expected_map(body, scheme)} == expected_map(body, scheme)
    assert check.problems == [] and f"turned from {axis} up" in match_source(other, body)
    assert np.allclose(got.root_translation, want.root_translation, atol=1e-6)
    assert np.allclose(np.abs(np.sum(got.local_rotations * want.local_rotations, -1)), 1.0, atol=1e-9)
    assert np.allclose(np.abs(np.sum(got.root_rotation * want.root_rotation, -1)), 1.0, atol=1e-9)


def match_source(path, body):
    """The source description the loader gives the clip (it says when the skeleton was turned or re-rooted)."""
    return load_clip(path, body, check=False).source


def test_a_joint_map_may_leave_out_the_root_bone_it_no_longer_sees(body, tmp_path):
    """After re-rooting, a joint map written for the whole file ({"root": null, "pelvis" on the hips}) still
    applies; one that makes a thigh the pelvis is refused, naming the map."""
    path = tmp_path / "rooted.bvh"
    path.write_text(with_floor_root(bvh_text(body, "unreal", "T")))
    jmap = tmp_path / "map.json"
    jmap.write_text(json.dumps({"root": None, "pelvis": "pelvis", "ik_foot_root": None}))
    _, match = load_clip(path, body, joint_map_file=jmap, with_match=True, check=False)
    assert match.mapping["pelvis"] == "pelvis" and match.mapping["left_hip"] == "thigh_l"
    jmap.write_text(json.dumps({"thigh_l": "pelvis"}))
    with pytest.raises(Exception, match="pelvis must be the skeleton's root"):
        load_clip(path, body, joint_map_file=jmap, check=False)
