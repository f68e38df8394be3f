"""Own motion: a BVH exported by Mixamo (`mixamorig:LeftUpLeg` names) converts through the Mixamo
table after namespace stripping; a skeleton with other names converts with `--joint-map FILE`; `pleat-motion joints`
and `convert` report which joints matched; bad joint maps are one-line errors."""
import json

import numpy as np
import pytest

from pleat.motion import load_clip
from pleat.motion import cli as motion_cli
from pleat.motion.clip import Clip
from pleat.motion.joint_map import MIXAMO_TO_BODY, match_joints, strip_namespace

ROT = "CHANNELS 3 Zrotation Yrotation Xrotation"          # Mixamo's order


def _joint(name, offset, children=(), channels=ROT):
    inner = "".join(children) if children else "End Site\n{\nOFFSET 0 5 0\n}\n"
    return f"JOINT {name}\n{{\nOFFSET {offset}\n{channels}\n{inner}}}\n"


def mixamo_bvh(prefix="mixamorig:", knee_deg=(0, 0, 90), frame_time="0.0333333"):
    """Mixamo's rig in a T-pose, centimetres, Y up, facing +Z (left = +X), with fingers and the *_End joints."""
    p = prefix
    fingers = lambda S, x: "".join(_joint(f"{p}{S}Hand{f}1", f"{x * 9} 0 {dz}", [
        _joint(f"{p}{S}Hand{f}2", f"{x * 3} 0 0", [_joint(f"{p}{S}Hand{f}3", f"{x * 2} 0 0")])])
        for f, dz in (("Thumb", 3), ("Index", 2), ("Middle", 0), ("Ring", -2), ("Pinky", -3)))
    arm = lambda S, x: _joint(f"{p}{S}Shoulder", f"{x * 6} 12 0", [_joint(f"{p}{S}Arm", f"{x * 12} 0 0", [
        _joint(f"{p}{S}ForeArm", f"{x * 27} 0 0", [_joint(f"{p}{S}Hand", f"{x * 25} 0 0", [fingers(S, x)])])])])
    leg = lambda S, x: _joint(f"{p}{S}UpLeg", f"{x * 9} -6 0", [_joint(f"{p}{S}Leg", "0 -42 0", [
        _joint(f"{p}{S}Foot", "0 -40 0", [_joint(f"{p}{S}ToeBase", "0 -6 12", [_joint(f"{p}{S}Toe_End",
                                                                                           "0 0 6")])])])])
    spine = _joint(f"{p}Spine", "0 10 0", [_joint(f"{p}Spine1", "0 12 0", [_joint(f"{p}Spine2", "0 12 0", [
        _joint(f"{p}Neck", "0 15 0", [_joint(f"{p}Head", "0 10 0", [_joint(f"{p}HeadTop_End", "0 18 0")])]),
        arm("Left", 1), arm("Right", -1)])])])
    hierarchy = (f"HIERARCHY\nROOT {p}Hips\n{{\nOFFSET 0 100 0\nCHANNELS 6 Xposition Yposition Zposition "
                 f"Zrotation Yrotation Xrotation\n{leg('Left', 1)}{leg('Right', -1)}{spine}}}\n")
    names = [ln.split()[1] for ln in hierarchy.splitlines() if ln.startswith(("ROOT", "JOINT"))]
    rows = []
    for t, knee in enumerate(knee_deg):
        vals = [0, 100, 10 * t, 0, 0, 0]
        for n in names[1:]:
            vals += [0, 0, knee if strip_namespace(n) == "LeftLeg" else 0]
        rows.append(" ".join(str(v) for v in vals))
    return (hierarchy + f"MOTION\nFrames: {len(rows)}\nFrame Time: {frame_time}\n" + "\n".join(rows) + "\n"), names


def _direction(body, clip, frame, a, b):
    J = clip.joint_positions(body)[frame]
    d = J[body.joint_index(b)] - J[body.joint_index(a)]
    return d / np.linalg.norm(d)


def test_namespaces_are_stripped():
    assert strip_namespace("mixamorig:LeftUpLeg") == "LeftUpLeg"
    assert strip_namespace("Armature|mixamorig:LeftUpLeg") == "LeftUpLeg"
    assert strip_namespace("mixamorig1_LeftUpLeg") == "LeftUpLeg"
    assert strip_namespace("LeftUpLeg") == "LeftUpLeg"


def test_the_mixamo_table_covers_every_body_joint(body):
    assert sorted(MIXAMO_TO_BODY.values()) == sorted(body.joint_names)


@pytest.mark.parametrize("prefix", ["mixamorig:", "mixamorig1_", ""])
def test_a_mixamo_bvh_converts_with_every_body_joint_matched(body, tmp_path, prefix, capsys):
    text, names = mixamo_bvh(prefix)
    (tmp_path / "mixamo.bvh").write_text(text)
    out = tmp_path / "mixamo.npz"
    assert motion_cli.main(["convert", str(tmp_path / "mixamo.bvh"), "--out", str(out), "--fps", "30"]) == 0
    captured = capsys.readouterr()
    report = json.loads(captured.out)
    assert report["frames"] == 3 and report["joints"]["matched"] == 24 and report["joints"]["unmatched"] == []
    # every animated joint the body has no place for is listed as unused: fingers beyond the middle base, the ends
    unused = {strip_namespace(n) for n in report["joints"]["unused"]}
    assert {"HeadTop_End", "LeftToe_End", "LeftHandIndex1", "RightHandThumb3"} <= unused
    assert "LeftHandMiddle1" not in unused and len(unused) == len(names) - 24
    assert f"left_hip        <- {prefix}LeftUpLeg  (structure; Mixamo table agrees)" in captured.err, \
        "the report goes to stderr"

    clip = Clip.load(out)
    assert np.isfinite(clip.local_rotations).all() and np.allclose(np.linalg.norm(clip.local_rotations, axis=-1), 1)
    # standing in the T-pose: shins down, arms horizontal (Mixamo's rest is a T-pose; the body's is an A-pose)
    assert _direction(body, clip, 0, "left_knee", "left_ankle")[1] < -0.95
    arm = _direction(body, clip, 0, "left_shoulder", "left_elbow")
    assert arm[0] > 0.95 and abs(arm[1]) < 0.1
    # Xrotation +90 at LeftLeg in the last frame folds the shin backwards (−Z); the right leg stays straight
    assert _direction(body, clip, 2, "left_knee", "left_ankle") @ np.array([0, 0, -1]) > 0.95
    assert _direction(body, clip, 2, "right_knee", "right_ankle")[1] < -0.95
    # the root moved 10 cm per frame along +Z, scaled by the leg-length ratio
    step = np.diff(clip.pelvis_positions()[:, 2])
    assert np.all(step > 0.05) and np.all(step < 0.15)


UNREAL = {"pelvis": "pelvis", "thigh_l": "left_hip", "calf_l": "left_knee", "foot_l": "left_ankle",
          "thigh_r": "right_hip", "calf_r": "right_knee", "foot_r": "right_ankle", "spine_01": "spine1"}


def unreal_bvh():
    """A skeleton with names no table knows (Unreal mannequin style)."""
    text, _ = mixamo_bvh("")
    for mixamo, unreal in (("LeftUpLeg", "thigh_l"), ("RightUpLeg", "thigh_r"), ("LeftLeg", "calf_l"),
                           ("RightLeg", "calf_r"), ("LeftFoot", "foot_l"), ("RightFoot", "foot_r"),
                           ("LeftToeBase", "ball_l"), ("RightToeBase", "ball_r"), ("Spine", "spine_01"),
                           ("Hips", "pelvis")):
        text = text.replace(f"JOINT {mixamo}\n", f"JOINT {unreal}\n").replace(f"ROOT {mixamo}\n",
                                                                              f"ROOT {unreal}\n")
    return text


def test_unknown_names_match_by_structure_and_a_joint_map_wins(body, tmp_path, capsys):
    bvh = tmp_path / "unreal.bvh"
    bvh.write_text(unreal_bvh())
    out = tmp_path / "unreal.npz"
    # no table knows thigh_l or calf_l: the skeleton's shape finds the legs (pleat.motion.structure)
    assert motion_cli.main(["convert", str(bvh), "--out", str(out), "--quiet"]) == 0
    assert json.loads(capsys.readouterr().out)["joints"]["matched"] == 24

    jmap = tmp_path / "unreal.json"
    jmap.write_text(json.dumps(dict(UNREAL, ball_l=None)))
    assert motion_cli.main(["joints", str(bvh), "--joint-map", str(jmap), "--json"]) == 0
    match = json.loads(capsys.readouterr().out)
    assert match["matched"]["left_hip"] == "thigh_l" and match["matched"]["spine1"] == "spine_01"
    assert match["matched"]["left_shoulder"] == "LeftArm", "names the map leaves out still match by the tables"
    assert "ball_l" not in match["matched"].values() and "ball_l" in match["unused"]
    assert motion_cli.main(["convert", str(bvh), "--out", str(out), "--joint-map", str(jmap), "--quiet"]) == 0
    clip = Clip.load(out)
    assert _direction(body, clip, 2, "left_knee", "left_ankle") @ np.array([0, 0, -1]) > 0.95

    # the same as the Mixamo file it was renamed from
    mixamo = tmp_path / "mixamo.bvh"
    mixamo.write_text(mixamo_bvh("")[0])
    ref = load_clip(mixamo, body)
    api = load_clip(bvh, body, joint_map_file=jmap)
    assert np.allclose(api.local_rotations[:, :10], ref.local_rotations[:, :10], atol=1e-9)


def test_joint_map_text_report_names_where_each_joint_came_from(tmp_path, capsys):
    bvh = tmp_path / "unreal.bvh"
    bvh.write_text(unreal_bvh())
    jmap = tmp_path / "m.json"
    jmap.write_text(json.dumps(UNREAL))
    assert motion_cli.main(["joints", str(bvh), "--joint-map", str(jmap)]) == 0
    text = capsys.readouterr().out
    assert "left_hip        <- thigh_l  (joint map)" in text
    assert "head            <- Head  (structure; Mixamo table agrees)" in text
    assert "left_foot       <- ball_l  (structure)" in text
    summary = next(ln for ln in text.splitlines() if "body joints matched" in ln)
    assert summary.startswith("  24 of 24 body joints matched; source joints unused: LeftToe_End, RightToe_End, ")
    assert "HeadTop_End" in summary and "LeftHandMiddle1" not in summary


@pytest.mark.parametrize("content,fragment", [
    ('{"thigh_l": "left_thigh"}', "'left_thigh' is not a body joint"),
    ('{"thigh_l": "left_hip", "thigh_r": "left_hip"}', "gives body joint 'left_hip' twice"),
    ('{"femur_l": "left_hip"}', "names 'femur_l', which the skeleton does not have"),
    ('{"thigh_l": "pelvis"}', "the body's pelvis must be the skeleton's root"),
    ('["thigh_l", "left_hip"]', "must be a JSON object"),
    ("{thigh_l: left_hip}", "not valid JSON"),
])
def test_a_bad_joint_map_is_one_line_naming_the_map(tmp_path, capsys, content, fragment):
    bvh = tmp_path / "unreal.bvh"
    bvh.write_text(unreal_bvh())
    jmap = tmp_path / "bad.json"
    jmap.write_text(content)
    out = tmp_path / "o.npz"
    assert motion_cli.main(["convert", str(bvh), "--out", str(out), "--joint-map", str(jmap)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"pleat-motion: error: {jmap}: ") and fragment in err[0], err
    assert not out.exists()


def test_a_joint_map_for_a_fixed_skeleton_is_refused(tmp_path, capsys):
    frame = [1 / 30, 0, 0.85, 0, 1, 0, 0, 0] + [1, 0, 0, 0] * 2 + [1, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0] * 2
    (tmp_path / "stand.txt").write_text(json.dumps({"Frames": [frame] * 3}))
    (tmp_path / "m.json").write_text('{"chest": "spine1"}')
    assert motion_cli.main(["convert", str(tmp_path / "stand.txt"), "--out", str(tmp_path / "o.npz"),
                            "--joint-map", str(tmp_path / "m.json")]) == 1
    assert "applies to BVH and ASF/AMC skeletons" in capsys.readouterr().err


def test_match_joints_keeps_the_root_as_pelvis_and_prefers_the_map():
    names = ["Root", "mixamorig:Hips", "mixamorig:LeftUpLeg", "mixamorig:LeftLeg", "mixamorig:LeftFoot",
             "mixamorig:RightUpLeg", "mixamorig:RightLeg", "mixamorig:RightFoot"]
    m = match_joints(names)
    assert m.mapping["pelvis"] == "Root", "the body's pelvis is the source root even when a child is called Hips"
    assert m.mapping["left_hip"] == "mixamorig:LeftUpLeg" and m.origin["left_hip"] == "Mixamo table"
    m = match_joints(names, {"LeftLeg": "left_hip", "LeftUpLeg": None})
    assert m.mapping["left_hip"] == "mixamorig:LeftLeg" and m.origin["left_hip"] == "joint map"
    assert "left_knee" not in m.mapping or m.mapping["left_knee"] != "mixamorig:LeftLeg"
    assert m.missing_required == ["left_knee"] and "mixamorig:LeftUpLeg" in m.unused
