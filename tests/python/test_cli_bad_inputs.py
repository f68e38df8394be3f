"""Malformed motion files: every CLI that reads a clip prints ONE line on stderr naming the
file and what is wrong, exits with status 1, and writes nothing. The corpus is generated here from small valid files
of each format (DeepMimic, BVH, ASF/AMC, AMASS npz, Pleat clip npz), each case breaking one thing; the valid bases
are checked to convert, so each failure is the mutation's."""
import io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pleat import show
from pleat.eval import cli as eval_cli
from pleat.motion import cli as motion_cli
from pleat.sim import cli as sim_cli
from synthetic_asf import asf_text

REPO = Path(__file__).resolve().parents[2]
ASSET = REPO / "assets" / "tshirt_xsmall.pleat"


# ---- valid bases ----------------------------------------------------------------------------------------------------
STAND = [1 / 30, 0, 0.85, 0, 1, 0, 0, 0] + [1, 0, 0, 0] * 2 + [1, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0] * 2


def deepmimic(frames=None, **top):
    frames = [list(STAND) for _ in range(3)] if frames is None else frames
    return json.dumps(dict(Loop="wrap", Frames=frames, **top))


def deepmimic_with(frame, column, value):
    """Three standing frames, frame `frame` value `column` replaced (a JSON literal, e.g. NaN)."""
    rows = [list(STAND) for _ in range(3)]
    rows[frame][column] = "@@"
    return deepmimic(rows).replace('"@@"', value)


_LEG = ("JOINT {S}UpLeg\n{{\nOFFSET {x} -5 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n"
        "JOINT {S}Leg\n{{\nOFFSET 0 -42 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n"
        "JOINT {S}Foot\n{{\nOFFSET 0 -41 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n"
        "End Site\n{{\nOFFSET 0 -5 12\n}}\n}}\n}}\n}}\n")
BVH_CHANNELS = 6 + 7 * 3


def bvh(frames=3, frame_time="0.04", rows=None, root_name="Hips"):
    """Hips, two legs and a spine in centimetres (CMU names), facing +Z."""
    hierarchy = (f"HIERARCHY\nROOT {root_name}\n{{\nOFFSET 0 0 0\n"
                 "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
                 + _LEG.format(S="Left", x=9) + _LEG.format(S="Right", x=-9)
                 + "JOINT Spine\n{\nOFFSET 0 10 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n"
                   "End Site\n{\nOFFSET 0 30 0\n}\n}\n}\n")
    if rows is None:
        rows = [" ".join(["0", "95", str(5 * t)] + ["0"] * (BVH_CHANNELS - 3)) for t in range(frames)]
    return hierarchy + f"MOTION\nFrames: {frames}\nFrame Time: {frame_time}\n" + "\n".join(rows) + "\n"


def bvh_value(text, frame, column, value):
    """The base BVH with motion value [frame, column] replaced by the word `value`."""
    head, _, data = text.partition("Frame Time: 0.04\n")
    rows = [r.split() for r in data.strip().splitlines()]
    rows[frame][column] = value
    return head + "Frame Time: 0.04\n" + "\n".join(" ".join(r) for r in rows) + "\n"


def bvh_deep(levels):
    opened = "".join(f"JOINT j{i}\n{{\nOFFSET 0 1 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n" for i in range(levels))
    return (f"HIERARCHY\nROOT Hips\n{{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
            f"Yrotation\n{opened}End Site\n{{\nOFFSET 0 1 0\n}}\n" + "}\n" * (levels + 1)
            + "MOTION\nFrames: 2\nFrame Time: 0.04\n" + ("0 " * (6 + 3 * levels) + "\n") * 2)


BONES = [("lhipjoint", "1 -0.5 0", 9, "0 0 0"), ("rhipjoint", "-1 -0.5 0", 9, "0 0 0"),
         ("lfemur", "0 -1 0", 42, "0 0 0"), ("ltibia", "0 -1 0", 41, "0 0 0"), ("lfoot", "0 0 1", 12, "0 0 0"),
         ("rfemur", "0 -1 0", 42, "0 0 0"), ("rtibia", "0 -1 0", 41, "0 0 0"), ("rfoot", "0 0 1", 12, "0 0 0")]
HIERARCHY = ["root lhipjoint rhipjoint", "lhipjoint lfemur", "rhipjoint rfemur", "lfemur ltibia", "ltibia lfoot",
             "rfemur rtibia", "rtibia rfoot"]


def asf(hierarchy_extra=()):
    return asf_text(BONES, HIERARCHY + list(hierarchy_extra))


def amc(frames=12, bad=None):
    out = [":FULLY-SPECIFIED", ":DEGREES"]
    for t in range(frames):
        out.append(str(t + 1))
        out.append(f"root 0 90 {t} 0 0 0")
        out += [f"{n} 0 0 0" for n, *_ in BONES]
    text = "\n".join(out) + "\n"
    if bad:
        text = text.replace(*bad, 1)
    return text


def npz(**arrays):
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def amass(T=3, **over):
    a = dict(poses=np.zeros((T, 156)), trans=np.tile([0.0, 0.0, 0.9], (T, 1)), mocap_framerate=np.array(60.0))
    a["poses"][:, 0] = np.pi / 2
    a.update(over)
    return npz(**{k: v for k, v in a.items() if v is not None})


def clip_npz(T=3, **over):
    from pleat.body.model import SMPL_JOINT_NAMES
    q = np.zeros((T, 24, 4))
    q[..., 3] = 1
    r = np.tile([0.0, 0.0, 0.0, 1.0], (T, 1))
    a = dict(name=np.array("c"), source=np.array(""), fps=np.float64(30), joint_names=np.array(SMPL_JOINT_NAMES),
             local_rotations=q, root_translation=np.zeros((T, 3)), root_rotation=r)
    a.update(over)
    return npz(**{k: v for k, v in a.items() if v is not None})


def _zero_quat_clip():
    q = np.zeros((3, 24, 4))
    q[..., 3] = 1
    q[1, 5] = 0
    return clip_npz(local_rotations=q)


def _legs_up(text):
    """The legs of bvh() turned to point up."""
    return text.replace("OFFSET 0 -42 0", "OFFSET 0 42 0").replace("OFFSET 0 -41 0", "OFFSET 0 41 0")


def _renamed_bvh(mapping):
    text = bvh()
    for a, b in mapping.items():
        text = text.replace(f"JOINT {a}\n", f"JOINT {b}\n").replace(f"ROOT {a}\n", f"ROOT {b}\n")
    return text


def _poses(T, bad=None):
    p = np.zeros((T, 156))
    if bad is not None:
        p[bad] = np.nan
    return p


# ---- the corpus: (case id, {file name: content}, fragment of the expected message[, the file the message names]) ----
# The first file is the one given to the CLI, and the one the message names unless a fourth entry says otherwise
# (an .amc whose .asf is broken); `None` content makes a folder.
CASES = [
    # DeepMimic JSON
    ("dm-empty", {"m.txt": ""}, "is empty"),
    ("dm-not-json", {"m.txt": "{Frames: [[0.03,"}, "is not JSON"),
    ("dm-top-level-list", {"m.txt": "[1, 2, 3]"}, 'no "Frames" list'),
    ("dm-no-frames", {"m.txt": '{"Loop": "wrap"}'}, 'no "Frames" list'),
    ("dm-frames-string", {"m.txt": '{"Frames": "all of them"}'}, 'no "Frames" list'),
    ("dm-zero-frames", {"m.txt": deepmimic([])}, "has 0 frames"),
    ("dm-one-frame", {"m.txt": deepmimic([STAND])}, "has 1 frame;"),
    ("dm-short-frame", {"m.txt": deepmimic([STAND, STAND[:43], STAND])}, "frame 1 has 43 values"),
    ("dm-frame-not-list", {"m.txt": deepmimic([STAND, 7, STAND])}, "frame 1 is not a list"),
    ("dm-string-value", {"m.txt": deepmimic_with(1, 9, '"x"')}, "not a number"),
    ("dm-null-value", {"m.txt": deepmimic_with(2, 3, "null")}, "not a number"),
    ("dm-bool-value", {"m.txt": deepmimic_with(0, 12, "true")}, "not a number"),
    ("dm-nan-root", {"m.txt": deepmimic_with(1, 2, "NaN")}, "frame 1, value 2 is nan"),
    ("dm-inf-quat", {"m.txt": deepmimic_with(0, 9, "Infinity")}, "must be finite"),
    ("dm-neg-inf", {"m.txt": deepmimic_with(2, 20, "-Infinity")}, "must be finite"),
    ("dm-zero-joint-quat", {"m.txt": deepmimic([STAND, STAND[:8] + [0, 0, 0, 0] + STAND[12:], STAND])},
     "chest rotation quaternion is zero"),
    ("dm-zero-root-quat", {"m.txt": deepmimic([STAND, STAND[:4] + [0, 0, 0, 0] + STAND[8:], STAND])},
     "root rotation quaternion is zero"),
    ("dm-all-zero-durations", {"m.txt": deepmimic([[0.0] + STAND[1:]] * 3)}, "every frame duration is 0"),
    ("dm-negative-duration", {"m.txt": deepmimic([STAND, [-0.1] + STAND[1:], STAND])}, "durations must be positive"),
    ("dm-one-zero-duration", {"m.txt": deepmimic([STAND, [0.0] + STAND[1:], STAND])}, "frame 1 has duration 0"),
    ("dm-absurd-duration", {"m.txt": deepmimic([[1e6] + STAND[1:]] * 3)}, "is outside"),
    ("dm-binary", {"m.txt": b"\x89PNG\r\n\x1a\n\x00\xff\xfe"}, "not a text file"),
    ("dm-deep-json", {"m.txt": "[" * 100000 + "]" * 100000}, "nests too deeply"),
    ("dm-huge-root", {"m.txt": deepmimic_with(1, 1, "1e300")}, "out of range"),
    # BVH
    ("bvh-empty", {"m.bvh": ""}, "is empty"),
    ("bvh-whitespace", {"m.bvh": "  \n\t\n"}, "is empty"),
    ("bvh-binary", {"m.bvh": b"\x00\xff\xfe\x01garbage"}, "not a text file"),
    ("bvh-no-hierarchy", {"m.bvh": bvh().replace("HIERARCHY", "HIERARCHIE")}, "expected 'HIERARCHY'"),
    ("bvh-no-root", {"m.bvh": bvh().replace("ROOT Hips", "JOINT Hips")}, "expected 'ROOT'"),
    ("bvh-root-no-brace", {"m.bvh": bvh().replace("ROOT Hips\n{", "ROOT Hips\n", 1)}, "expected '{'"),
    ("bvh-cut-in-hierarchy", {"m.bvh": bvh().split("JOINT LeftFoot")[0]}, "ends early"),
    ("bvh-missing-close-brace", {"m.bvh": bvh().replace("}\n}\nMOTION", "}\nMOTION")}, "unexpected 'MOTION'"),
    ("bvh-channels-word", {"m.bvh": bvh().replace("CHANNELS 3", "CHANNELS three", 1)}, "not an integer"),
    ("bvh-channels-seven", {"m.bvh": bvh().replace("CHANNELS 3", "CHANNELS 7", 1)}, "0 to 6 channels"),
    ("bvh-unknown-channel", {"m.bvh": bvh().replace("CHANNELS 3 Zrotation", "CHANNELS 3 Wrotation", 1)},
     "unknown channel 'Wrotation'"),
    ("bvh-channel-twice", {"m.bvh": bvh().replace("CHANNELS 3 Zrotation Xrotation", "CHANNELS 3 Zrotation Zrotation",
                                                  1)}, "listed twice"),
    ("bvh-offset-word", {"m.bvh": bvh().replace("OFFSET 9 -5 0", "OFFSET 9 abc 0")}, "not a number"),
    ("bvh-offset-nan", {"m.bvh": bvh().replace("OFFSET 9 -5 0", "OFFSET 9 nan 0")}, "must be finite"),
    ("bvh-offset-inf", {"m.bvh": bvh().replace("OFFSET 0 -42 0", "OFFSET 0 -inf 0", 1)}, "must be finite"),
    ("bvh-no-offset", {"m.bvh": bvh().replace("OFFSET 0 10 0\n", "")}, "has no OFFSET"),
    ("bvh-unexpected-word", {"m.bvh": bvh().replace("OFFSET 0 10 0\n", "OFFSET 0 10 0\nSCALE 1 1 1\n")},
     "unexpected 'SCALE'"),
    ("bvh-end-site-channels", {"m.bvh": bvh().replace("End Site\n{\nOFFSET 0 30 0\n",
                                                      "End Site\n{\nOFFSET 0 30 0\nCHANNELS 1 Xrotation\n")},
     "End Site of 'Spine' has CHANNELS"),
    ("bvh-root-name-missing", {"m.bvh": "HIERARCHY\nROOT"}, "ends early"),
    ("bvh-no-motion-word", {"m.bvh": bvh().replace("MOTION", "MOTON")}, "expected 'MOTION'"),
    ("bvh-no-motion-section", {"m.bvh": bvh().split("MOTION")[0]}, "ends early: expected 'MOTION'"),
    ("bvh-frames-word", {"m.bvh": bvh().replace("Frames: 3", "Frames: three")}, "not an integer"),
    ("bvh-zero-frames", {"m.bvh": bvh(frames=0)}, "has 0 frames"),
    ("bvh-one-frame", {"m.bvh": bvh(frames=1)}, "has 1 frame"),
    ("bvh-negative-frames", {"m.bvh": bvh().replace("Frames: 3", "Frames: -3")}, "Frames: -3"),
    ("bvh-frame-time-zero", {"m.bvh": bvh(frame_time="0")}, "Frame Time is 0"),
    ("bvh-frame-time-negative", {"m.bvh": bvh(frame_time="-0.04")}, "Frame Time is -0.04"),
    ("bvh-frame-time-nan", {"m.bvh": bvh(frame_time="nan")}, "must be finite"),
    ("bvh-frame-time-inf", {"m.bvh": bvh(frame_time="inf")}, "must be finite"),
    ("bvh-frame-time-tiny", {"m.bvh": bvh(frame_time="1e-9")}, "frame rate"),
    ("bvh-frame-time-missing", {"m.bvh": bvh().replace("Frame Time: 0.04\n", "")}, "expected 'Frame'"),
    ("bvh-truncated-motion", {"m.bvh": bvh().rstrip()[:-10]}, "complete frames"),
    ("bvh-extra-values", {"m.bvh": bvh() + "1 2 3\n"}, "values more than"),
    ("bvh-value-word", {"m.bvh": bvh_value(bvh(), 1, 7, "abc")}, "'abc' (frame 1) is not a number"),
    ("bvh-value-nan", {"m.bvh": bvh_value(bvh(), 2, 10, "nan")}, "must be finite"),
    ("bvh-value-inf", {"m.bvh": bvh_value(bvh(), 0, 4, "-inf")}, "must be finite"),
    ("bvh-huge-root", {"m.bvh": bvh_value(bvh(), 1, 0, "1e300")}, "out of range"),
    ("bvh-deeply-nested", {"m.bvh": bvh_deep(5000)}, "nest more than"),
    ("bvh-duplicate-joint", {"m.bvh": bvh().replace("JOINT RightUpLeg", "JOINT LeftUpLeg")}, "appears twice"),
    # unknown names on chains that are no legs (they point up): neither the structure nor the names find legs
    ("bvh-unknown-names", {"m.bvh": _legs_up(_renamed_bvh({n: f"bone{i}" for i, n in enumerate(
        ["LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg", "RightFoot", "Spine"])}))},
     "no source joint for left_hip"),
    ("bvh-mixamo-no-legs", {"m.bvh": _legs_up(_renamed_bvh({"Hips": "mixamorig:Hips", **{
        f"{s}{p}": f"mixamorig:{s}Arm{p}" for s in ("Left", "Right") for p in ("UpLeg", "Leg", "Foot")}}))},
     "no source joint for left_hip"),
    ("bvh-zero-legs", {"m.bvh": bvh().replace("OFFSET 0 -42 0", "OFFSET 0 0 0").replace("OFFSET 0 -41 0",
                                                                                          "OFFSET 0 0 0")},
     "zero length"),
    ("bvh-hips-together", {"m.bvh": bvh().replace("OFFSET 9 -5 0", "OFFSET 0 -5 0").replace("OFFSET -9 -5 0",
                                                                                            "OFFSET 0 -5 0")},
     "not apart sideways"),
    ("bvh-no-channels", {"m.bvh": "\n".join(ln for ln in bvh().splitlines() if not ln.startswith("CHANNELS")
                                            and not ln[:1].isdigit()) + "\n"}, "has no CHANNELS"),
    ("bvh-shorter-than-a-frame", {"m.bvh": bvh(frames=2, frame_time="0.001")}, "lasts"),
    # files that are not there or not motion
    ("missing-file", {}, "no such file or clip name"),
    ("folder", {"m.bvh": None}, "is a folder"),
    ("unknown-suffix", {"m.fbx": "Kaydara FBX Binary"}, "unknown motion format '.fbx'"),
    # Acclaim ASF/AMC
    ("amc-no-asf", {"m.amc": amc()}, "no ASF skeleton m.asf"),
    ("amc-zero-frames", {"m.amc": amc(0), "m.asf": asf()}, "has 0 frames"),
    ("amc-one-frame", {"m.amc": amc(1), "m.asf": asf()}, "has 1 frame"),
    ("amc-nan", {"m.amc": amc(bad=("ltibia 0 0 0", "ltibia 0 nan 0")), "m.asf": asf()}, "non-finite"),
    ("amc-unknown-bone", {"m.amc": amc(bad=("ltibia 0 0 0", "lknee 0 0 0")), "m.asf": asf()}, "'lknee' is not in"),
    ("amc-too-few-values", {"m.amc": amc(bad=("ltibia 0 0 0", "ltibia 0 0")), "m.asf": asf()}, "needs 3 numbers"),
    ("amc-word-value", {"m.amc": amc(bad=("ltibia 0 0 0", "ltibia 0 x 0")), "m.asf": asf()}, "are not numbers"),
    ("asf-undefined-bone", {"m.amc": amc(), "m.asf": asf(hierarchy_extra=["lfoot ltoes"])}, "does not define",
     "m.asf"),
    ("asf-empty", {"m.amc": amc(), "m.asf": ""}, "is empty", "m.asf"),
    ("asf-nan-direction", {"m.amc": amc(), "m.asf": asf().replace("direction 1 -0.5 0", "direction 1 nan 0")},
     "non-finite", "m.asf"),
    # AMASS npz
    ("amass-not-zip", {"m.npz": b"this is not a zip file"}, "not an npz file"),
    ("amass-empty-file", {"m.npz": b""}, "not an npz file"),
    ("amass-no-poses", {"m.npz": amass(poses=None)}, "without poses"),
    ("amass-no-rate", {"m.npz": amass(mocap_framerate=None)}, "without mocap_framerate"),
    ("amass-poses-shape", {"m.npz": amass(poses=np.zeros((3, 10)))}, "poses has shape"),
    ("amass-nan-poses", {"m.npz": amass(poses=_poses(3, (1, 7)))}, "non-finite"),
    ("amass-zero-frames", {"m.npz": amass(T=0)}, "has 0 frames"),
    ("amass-one-frame", {"m.npz": amass(T=1)}, "has 1 frame"),
    ("amass-zero-rate", {"m.npz": amass(mocap_framerate=np.array(0.0))}, "positive frame rate"),
    ("amass-trans-shape", {"m.npz": amass(trans=np.zeros((2, 3)))}, "trans has shape"),
    # Pleat clip npz
    ("clip-zero-quat", {"m.npz": _zero_quat_clip()}, "quaternion is zero"),
    ("clip-nan-translation", {"m.npz": clip_npz(root_translation=np.full((3, 3), np.nan))}, "not finite"),
    ("clip-one-frame", {"m.npz": clip_npz(T=1)}, "has 1 frame"),
    ("clip-zero-fps", {"m.npz": clip_npz(fps=np.float64(0))}, "frame rate 0"),
    ("clip-wrong-joints", {"m.npz": clip_npz(joint_names=np.array([f"j{i}" for i in range(24)]))},
     "are not the body's"),
    ("clip-no-root-rotation", {"m.npz": clip_npz(root_rotation=None)}, "without root_rotation"),
]
VALID = [("dm", {"m.txt": deepmimic()}), ("bvh", {"m.bvh": bvh()}), ("amc", {"m.amc": amc(), "m.asf": asf()}),
         ("amass", {"m.npz": amass()}), ("clip", {"m.npz": clip_npz()})]


def _write(folder, files, case_id):
    """Writes the case into folder/case_id/ and returns the path handed to the CLI."""
    d = folder / case_id
    d.mkdir()
    for name, content in files.items():
        p = d / name
        if content is None:
            p.mkdir()
        elif isinstance(content, bytes):
            p.write_bytes(content)
        else:
            p.write_text(content)
    return d / (next(iter(files)) if files else "absent.bvh")


def _listing(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def test_the_corpus_is_large_and_the_valid_bases_convert(tmp_path, capsys):
    assert len(CASES) >= 50 and len({c[0] for c in CASES}) == len(CASES)
    for case_id, files in VALID:
        path = _write(tmp_path, files, case_id)
        out = tmp_path / f"{case_id}_out.npz"
        assert motion_cli.main(["convert", str(path), "--out", str(out), "--quiet"]) == 0, capsys.readouterr().err
        assert out.is_file()


def _run(cli, path, out):
    if cli == "pleat-motion":
        return motion_cli.main(["convert", str(path), "--out", str(out / "clip.npz")])
    if cli == "pleat-eval":
        return eval_cli.main(["--asset", str(ASSET), "--motion", str(path), "--out", str(out / "report.json"),
                              "--plots", str(out / "plots"), "--quiet"])
    if cli == "pleat-show":
        return show.main(["--garment", "tshirt", "--motion", str(path), "--out", str(out / "show.png")])
    return sim_cli.main(["--garment", "tshirt", "--motion", str(path), "--out", str(out / "sim"), "--quiet"])


@pytest.mark.parametrize("cli", ["pleat-motion", "pleat-eval", "pleat-show", "pleat-sim"])
def test_every_malformed_motion_file_gives_one_line_a_failure_status_and_no_output(cli, tmp_path, capsys):
    if cli == "pleat-eval" and not ASSET.is_file():
        pytest.skip(f"{ASSET} missing")
    problems = []
    for case_id, files, fragment, *named in CASES:
        path = _write(tmp_path, files, case_id)
        named = path.with_name(named[0]) if named else path
        out = tmp_path / "out"
        out.mkdir()
        before = _listing(tmp_path)
        rc = _run(cli, path, out)
        captured = capsys.readouterr()
        lines = [ln for ln in captured.err.splitlines() if ln.strip()]
        ok = (rc == 1 and len(lines) == 1 and lines[0].startswith(f"{cli}: error: {named}")
              and fragment in lines[0] and "Traceback" not in captured.err and captured.out == ""
              and _listing(tmp_path) == before and not any(out.iterdir()))
        if not ok:
            problems.append(f"{case_id}: rc={rc} stderr={captured.err.strip()[:300]!r} "
                            f"new files={sorted(set(_listing(tmp_path)) - set(before))}")
        out.rmdir()
    assert not problems, "\n".join(problems)


def test_console_script_prints_one_line_not_a_traceback(tmp_path):
    """The same through a real process: exit status 1, one stderr line, no file."""
    path = _write(tmp_path, {"walk.bvh": bvh(frame_time="0")}, "ft0")
    out = tmp_path / "walk.npz"
    run = subprocess.run([sys.executable, "-m", "pleat.motion.cli", "convert", str(path), "--out", str(out)],
                         capture_output=True, text=True, timeout=120, cwd=REPO)
    assert run.returncode == 1
    assert run.stderr.strip().splitlines() == [f"pleat-motion: error: {path}: Frame Time is 0: it must be a positive "
                                               "number of seconds per frame"]
    assert not out.exists()


def test_a_failing_convert_keeps_the_previous_output(tmp_path, capsys):
    """A good clip converted, then a bad one to the same --out: the good file is still there, unchanged."""
    good = _write(tmp_path, {"m.bvh": bvh()}, "good")
    bad = _write(tmp_path, {"m.bvh": bvh(frame_time="0")}, "bad")
    out = tmp_path / "clip.npz"
    assert motion_cli.main(["convert", str(good), "--out", str(out), "--quiet"]) == 0
    before = out.read_bytes()
    assert motion_cli.main(["convert", str(bad), "--out", str(out)]) == 1
    assert out.read_bytes() == before
    assert "Frame Time is 0" in capsys.readouterr().err


# ---- the other inputs: assets, weights, garments, bodies, joint maps ------------------------------------------------
def _other_cases(d):
    """(cli, main, argv, the path the line names, fragment); every output path lies under d/out."""
    from pleat import garment_asset, pack, render_export
    from pleat.body import cli as body_cli
    from pleat.garment import cli as garment_cli
    junk = d / "junk.npz"
    junk.write_text("not a zip")
    junk_asset = d / "junk.pleat"
    junk_asset.write_bytes(b"PLEATAST" + bytes(40))
    clip = d / "walk.bvh"
    clip.write_text(bvh())
    out = d / "out"
    return [
        ("pleat-eval", eval_cli.main, ["--asset", str(junk_asset), "--motion", str(clip), "--out", str(out / "r.json")],
         junk_asset, "not a valid Pleat asset"),
        ("pleat-eval", eval_cli.main, ["--asset", str(d / "absent.pleat"), "--motion", str(clip), "--out",
                                       str(out / "r.json")], d / "absent.pleat", "No such file"),
        ("pleat-pack", pack.main, [str(junk), "--out", str(out / "a.pleat")], junk, "not an npz file"),
        ("pleat-pack", pack.main, ["--info", str(junk_asset)], junk_asset, "not a valid Pleat asset"),
        ("pleat-sim", sim_cli.main, ["--garment", str(junk), "--motion", str(clip), "--out", str(out / "s")], junk,
         "not a garment npz"),
        ("pleat-show", show.main, ["--garment", "poncho", "--out", str(out / "s.png")], "poncho", "no such garment"),
        ("pleat-show", show.main, ["--garment", "tshirt", "--sim", str(d), "--out", str(out / "s.png")], d,
         "no sim.npz in it"),
        ("pleat-body", body_cli.main, ["info", str(junk)], junk, "not a body npz"),
        ("pleat-sim", sim_cli.main, ["--garment", "tshirt", "--motion", str(clip), "--body", str(d / "absent.npz"),
                                     "--out", str(out / "s")], d / "absent.npz", "no such body file"),
        ("pleat-garment", garment_cli.main, ["--from-obj", str(d / "absent.obj"), "--out", str(out / "g.npz")],
         d / "absent.obj", "no such OBJ file"),
        ("pleat-garment-asset", garment_asset.main, ["--garment", str(junk), "--out", str(out / "g.pleat")], junk,
         "not a garment npz"),
        ("pleat-render-export", render_export.main, ["motion", "--clip", str(d / "absent.bvh"), "--out",
                                                     str(out / "c.bin")], d / "absent.bvh", "no such file"),
        ("pleat-motion", motion_cli.main, ["convert", str(clip), "--joint-map", str(d / "absent.json"), "--out",
                                           str(out / "c.npz")], d / "absent.json", "joint map file not found"),
    ]


def test_a_missing_shipped_body_is_an_error_that_names_the_command_that_builds_it(tmp_path, monkeypatch, capsys):
    """No stand-in body: without assets/body.npz every command that needs the body stops with one line naming
    `pleat-body export`."""
    from pleat import paths
    from pleat.cli import InputError
    from pleat.sim.scene import load_body
    absent = tmp_path / "assets" / "body.npz"
    monkeypatch.setattr(paths, "BODY_PATH", absent)
    with pytest.raises(InputError, match="pleat-body export"):
        load_body()
    (tmp_path / "out").mkdir()
    clip = tmp_path / "walk.bvh"
    clip.write_text(bvh())
    before = _listing(tmp_path)
    out = tmp_path / "out"
    for cli, main, argv in [("pleat-sim", sim_cli.main, ["--garment", "tshirt", "--motion", str(clip), "--out",
                                                         str(out / "s")]),
                            ("pleat-show", show.main, ["--garment", "tshirt", "--out", str(out / "s.png")])]:
        assert main(argv) == 1
        lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
        assert len(lines) == 1 and lines[0].startswith(f"{cli}: error: {absent}: ") and "pleat-body export" in lines[0]
    assert _listing(tmp_path) == before


def test_other_bad_inputs_give_one_line_and_no_output(tmp_path, capsys):
    problems = []
    for cli, main, argv, named, fragment in _other_cases(tmp_path):
        (tmp_path / "out").mkdir(exist_ok=True)
        before = _listing(tmp_path)
        rc = main(argv)
        captured = capsys.readouterr()
        lines = [ln for ln in captured.err.splitlines() if ln.strip()]
        if not (rc == 1 and len(lines) == 1 and lines[0].startswith(f"{cli}: error: {named}: ")
                and fragment in lines[0] and _listing(tmp_path) == before):
            problems.append(f"{cli} {argv[:2]}: rc={rc} stderr={captured.err.strip()[:300]!r}")
    assert not problems, "\n".join(problems)
