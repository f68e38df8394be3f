"""Motion loaders → `Clip` on the Pleat body: DeepMimic (JSON .txt), BVH, Acclaim ASF/AMC, AMASS-style npz.

Clips are found in $PLEAT_MOTION_DIR, then ../shared/motion beside the repository, then data/motion in it (where
scripts/fetch-motion.sh writes). See docs/motion.md.
"""
import json
import os
from pathlib import Path

import numpy as np

from pleat.body.model import BodyModel, SMPL_JOINT_NAMES, SMPL_PARENTS
from pleat.motion.clip import Clip
from pleat.motion.retarget import SourceMotion, retarget
from pleat.rotations import axis_angle_to_matrix, quat_to_matrix

REPO_ROOT = Path(__file__).resolve().parents[3]


def motion_dirs():
    dirs = []
    if os.environ.get("PLEAT_MOTION_DIR"):
        dirs.append(Path(os.environ["PLEAT_MOTION_DIR"]))
    dirs += [REPO_ROOT.parent / "shared" / "motion", REPO_ROOT / "data" / "motion"]
    return dirs


def find_motion_dir():
    for d in motion_dirs():
        if d.is_dir():
            return d
    raise FileNotFoundError("no motion folder: set PLEAT_MOTION_DIR or run scripts/fetch-motion.sh "
                            f"(looked in {[str(d) for d in motion_dirs()]})")


_SUFFIXES = (".txt", ".json", ".bvh", ".amc", ".npz")


def list_clips(motion_dir=None):
    """Clip names (paths relative to the motion folder, without suffix) → file paths."""
    root = Path(motion_dir) if motion_dir else find_motion_dir()
    out = {}
    for p in sorted(root.rglob("*")):
        if p.suffix not in _SUFFIXES or not p.is_file() or p.name.upper().startswith(("LICENSE", "PROVENANCE")):
            continue
        out[str(p.relative_to(root).with_suffix(""))] = p
    return out


def resolve_clip(name_or_path, motion_dir=None):
    p = Path(name_or_path)
    if p.is_file():
        return p
    clips = list_clips(motion_dir)
    key = str(Path(name_or_path).with_suffix("")) if Path(name_or_path).suffix in _SUFFIXES else name_or_path
    if key in clips:
        return clips[key]
    hits = [v for k, v in clips.items() if k.endswith("/" + key) or Path(k).name == key]
    if len(hits) == 1:
        return hits[0]
    raise FileNotFoundError(f"no clip {name_or_path!r} ({len(hits)} matches)")


def load_clip(name_or_path, body=None, motion_dir=None, **kw):
    """Any supported file or clip name → Clip retargeted onto `body` (default: assets/body.npz)."""
    path = resolve_clip(name_or_path, motion_dir)
    body = body or BodyModel.load()
    if path.suffix == ".bvh":
        return load_bvh(path, body, **kw)
    if path.suffix == ".amc":
        return load_asf_amc(path, body, **kw)
    if path.suffix == ".npz":
        return load_amass(path, body, **kw)
    return load_deepmimic(path, body, **kw)


def _clip_name(path):
    path = Path(path)
    try:
        root = find_motion_dir()
        return str(path.resolve().relative_to(root.resolve()).with_suffix(""))
    except (ValueError, FileNotFoundError):
        return path.stem


def _uniform(times, local, root_pos):
    """Frames at irregular times → uniform frames at the median rate (slerp / lerp)."""
    dt = np.diff(times)
    step = float(np.median(dt))
    fps = 1.0 / step
    if np.allclose(dt, step, rtol=1e-3, atol=1e-6):
        return fps, local, root_pos
    from pleat.rotations import matrix_to_quat, quat_slerp
    n = int(round((times[-1] - times[0]) * fps)) + 1
    t = times[0] + np.arange(n) / fps
    i1 = np.clip(np.searchsorted(times, t, side="right"), 1, len(times) - 1)
    i0 = i1 - 1
    a = np.clip((t - times[i0]) / np.maximum(times[i1] - times[i0], 1e-12), 0, 1)
    q = matrix_to_quat(local)
    qs = quat_slerp(q[i0], q[i1], np.broadcast_to(a[:, None], (n, q.shape[1])))
    pos = root_pos[i0] * (1 - a[:, None]) + root_pos[i1] * a[:, None]
    return fps, quat_to_matrix(qs), pos


# ---- DeepMimic ---------------------------------------------------------------------------------------------------
# humanoid3d: 13 bodies. Frame = [dt, root pos (3), root quat (w,x,y,z), then per joint below a quaternion (w,x,y,z)
# or, for knees and elbows, one angle (rad) about the joint's z axis]. The rest pose (all rotations identity) stands
# facing +X with the arms hanging down, right side at +Z; offsets (m) from DeepMimic's data/characters/humanoid3d.txt.
DEEPMIMIC_JOINTS = [  # name, parent, offset from parent, dofs (4 = quaternion, 1 = revolute about z)
    ("root", -1, (0.0, 0.0, 0.0), 4),
    ("chest", 0, (0.0, 0.236151, 0.0), 4),
    ("neck", 1, (0.0, 0.223894, 0.0), 4),
    ("right_hip", 0, (0.0, 0.0, 0.084887), 4),
    ("right_knee", 3, (0.0, -0.421546, 0.0), 1),
    ("right_ankle", 4, (0.0, -0.40987, 0.0), 4),
    ("right_shoulder", 1, (-0.02405, 0.24350, 0.18311), 4),
    ("right_elbow", 6, (0.0, -0.274788, 0.0), 1),
    ("left_hip", 0, (0.0, 0.0, -0.084887), 4),
    ("left_knee", 8, (0.0, -0.421546, 0.0), 1),
    ("left_ankle", 9, (0.0, -0.40987, 0.0), 4),
    ("left_shoulder", 1, (-0.02405, 0.24350, -0.18311), 4),
    ("left_elbow", 11, (0.0, -0.274788, 0.0), 1),
]
# end sites (no data): give the forearms their rest direction
DEEPMIMIC_ENDS = [("right_wrist", 7, (0.0, -0.258947, 0.0)), ("left_wrist", 12, (0.0, -0.258947, 0.0))]
DEEPMIMIC_MAP = {"pelvis": "root", "spine3": "chest", "head": "neck",
                 **{f"{s}_{j}": f"{s}_{j}" for s in ("left", "right") for j in ("hip", "knee", "ankle")},
                 **{f"{s}_{b}": f"{s}_{d}" for s in ("left", "right")
                    for b, d in (("shoulder", "shoulder"), ("elbow", "elbow"))}}
DEEPMIMIC_SPREAD = {"spine3": ["spine1", "spine2", "spine3"], "head": ["neck", "head"]}


def _wxyz_to_matrix(q):
    q = np.asarray(q, dtype=np.float64)
    return quat_to_matrix(np.concatenate([q[..., 1:4], q[..., 0:1]], axis=-1))


def _skeleton_rest(joints):
    pos = np.zeros((len(joints), 3))
    for i, (_, p, off, *_rest) in enumerate(joints):
        pos[i] = (pos[p] if p >= 0 else 0.0) + np.asarray(off)
    return pos


def read_deepmimic(path):
    """DeepMimic JSON → SourceMotion (source units: metres, +Y up)."""
    with open(path) as fh:
        data = json.load(fh)
    frames = np.asarray(data["Frames"], dtype=np.float64)
    if frames.ndim != 2 or frames.shape[1] != 44:
        raise ValueError(f"{path}: expected humanoid3d frames of 44 values, got {frames.shape}")
    dt = frames[:, 0]
    times = np.concatenate([[0.0], np.cumsum(dt[:-1])])
    T = len(frames)
    joints = DEEPMIMIC_JOINTS + [(n, p, off, 0) for n, p, off in DEEPMIMIC_ENDS]
    local = np.broadcast_to(np.eye(3), (T, len(joints), 3, 3)).copy()
    col = 4
    for i, (_, _, _, dof) in enumerate(DEEPMIMIC_JOINTS):
        if dof == 4:
            local[:, i] = _wxyz_to_matrix(frames[:, col:col + 4])
        else:
            aa = np.zeros((T, 3))
            aa[:, 2] = frames[:, col]
            local[:, i] = axis_angle_to_matrix(aa)
        col += dof
    fps, local, root = _uniform(times, local, frames[:, 1:4])
    return SourceMotion(name=_clip_name(path), source=f"DeepMimic humanoid3d {Path(path).name}", fps=fps,
                        names=[j[0] for j in joints], parents=np.array([j[1] for j in joints]),
                        rest_positions=_skeleton_rest(joints), local_rotations=local, root_positions=root)


def load_deepmimic(path, body=None, **kw):
    body = body or BodyModel.load()
    return retarget(read_deepmimic(path), DEEPMIMIC_MAP, body, spread=DEEPMIMIC_SPREAD, **kw)


# ---- generic name map (BVH, ASF) -----------------------------------------------------------------------------------
_SIDE_CANDIDATES = {
    "hip": ["{S}UpLeg", "{S}Hip", "{s}Thigh", "{S}Thigh", "{s}femur"],
    "knee": ["{S}Leg", "{S}Knee", "{s}Shin", "{S}Shin", "{s}tibia"],
    "ankle": ["{S}Foot", "{S}Ankle", "{s}Foot", "{s}foot"],
    "foot": ["{S}ToeBase", "{S}Toe", "{S}Toes", "{s}Toe", "{s}toes"],
    "collar": ["{S}Shoulder", "{S}Collar", "{s}Collar", "{s}clavicle"],
    "shoulder": ["{S}Arm", "{S}UpArm", "{S}UpperArm", "{s}Shldr", "{s}humerus"],
    "elbow": ["{S}ForeArm", "{S}Elbow", "{S}LowerArm", "{s}ForeArm", "{s}radius"],
    "wrist": ["{S}Hand", "{S}Wrist", "{s}Hand", "{s}wrist"],
    "hand": ["{S}HandMiddle1", "{S}HandIndex1", "{S}FingerBase", "{s}hand"],
}
_CENTER_CANDIDATES = {
    "pelvis": ["Hips", "hip", "Hip", "pelvis", "Pelvis", "root"],
    "spine1": ["Spine", "LowerBack", "lowerback", "Abdomen", "abdomen", "spine"],
    "spine2": ["Spine1", "Chest", "chest", "upperback"],
    "spine3": ["Spine2", "Chest2", "UpperChest", "thorax", "Spine3"],
    "neck": ["Neck", "neck", "lowerneck", "Neck1"],
    "head": ["Head", "head"],
}


def guess_joint_map(source_names):
    """Body joint → source joint by common naming schemes (CMU BVH, Mixamo, Biovision, Acclaim/CMU ASF)."""
    names = list(source_names)
    lower = {n.lower(): n for n in names}
    used, out = set(), {}

    def pick(cands):
        for c in cands:
            for n in (c, c.lower()):
                hit = n if n in names else lower.get(n.lower())
                if hit and hit not in used:
                    return hit
        return None

    for joint, cands in _CENTER_CANDIDATES.items():
        hit = pick(cands)
        if hit:
            out[joint], _ = hit, used.add(hit)
    for side, S, s in (("left", "Left", "l"), ("right", "Right", "r")):
        for part, cands in _SIDE_CANDIDATES.items():
            hit = pick([c.format(S=S, s=s) for c in cands])
            if hit:
                out[f"{side}_{part}"], _ = hit, used.add(hit)
    out["pelvis"] = names[0]
    return out


def _euler(order, angles_deg, intrinsic):
    """Rotation from Euler angles (degrees) about the axes in `order` (e.g. "ZXY"). intrinsic (BVH): R = R1·R2·R3;
    otherwise (Acclaim: the first listed axis is applied first): R = R3·R2·R1."""
    angles = np.deg2rad(np.asarray(angles_deg, dtype=np.float64))
    R = np.broadcast_to(np.eye(3), angles.shape[:-1] + (3, 3)).copy()
    for i, ax in enumerate(order.upper()):
        aa = np.zeros(angles.shape[:-1] + (3,))
        aa[..., "XYZ".index(ax)] = angles[..., i]
        Ri = axis_angle_to_matrix(aa)
        R = R @ Ri if intrinsic else Ri @ R
    return R


# ---- BVH -----------------------------------------------------------------------------------------------------------
def read_bvh(path):
    tokens = Path(path).read_text().split()
    pos = 0
    names, parents, offsets, channels = [], [], [], []

    def expect(tok):
        nonlocal pos
        if tokens[pos] != tok:
            raise ValueError(f"{path}: expected {tok!r}, found {tokens[pos]!r}")
        pos += 1

    def parse_joint(parent):
        nonlocal pos
        kind = tokens[pos]
        pos += 1
        if kind == "End":
            expect("Site")
            name = f"{names[parent]}_end"
        else:
            name = tokens[pos]
            pos += 1
        expect("{")
        idx = len(names)
        names.append(name)
        parents.append(parent)
        offsets.append([0.0, 0.0, 0.0])
        channels.append([])
        while tokens[pos] != "}":
            t = tokens[pos]
            if t == "OFFSET":
                offsets[idx] = [float(x) for x in tokens[pos + 1:pos + 4]]
                pos += 4
            elif t == "CHANNELS":
                n = int(tokens[pos + 1])
                channels[idx] = tokens[pos + 2:pos + 2 + n]
                pos += 2 + n
            elif t in ("JOINT", "End"):
                parse_joint(idx)
            else:
                raise ValueError(f"{path}: unexpected token {t!r}")
        pos += 1

    expect("HIERARCHY")
    expect("ROOT")
    pos -= 1
    tokens[pos] = "JOINT"
    parse_joint(-1)
    expect("MOTION")
    expect("Frames:")
    n_frames = int(tokens[pos])
    pos += 1
    expect("Frame")
    expect("Time:")
    frame_time = float(tokens[pos])
    pos += 1
    n_ch = sum(len(c) for c in channels)
    values = np.asarray(tokens[pos:pos + n_frames * n_ch], dtype=np.float64)
    if values.size != n_frames * n_ch:
        raise ValueError(f"{path}: expected {n_frames} frames of {n_ch} channels")
    values = values.reshape(n_frames, n_ch)
    offsets = np.asarray(offsets)
    rest = np.zeros_like(offsets)
    for i, p in enumerate(parents):
        rest[i] = offsets[i] + (rest[p] if p >= 0 else 0.0)
    local = np.broadcast_to(np.eye(3), (n_frames, len(names), 3, 3)).copy()
    root = np.broadcast_to(offsets[0], (n_frames, 3)).copy()
    col = 0
    for i, ch in enumerate(channels):
        block = values[:, col:col + len(ch)]
        col += len(ch)
        rot_axes = [c[0] for c in ch if c.lower().endswith("rotation")]
        rot_cols = [j for j, c in enumerate(ch) if c.lower().endswith("rotation")]
        if rot_axes:
            local[:, i] = _euler("".join(rot_axes), block[:, rot_cols], intrinsic=True)
        if i == 0:
            for j, c in enumerate(ch):
                if c.lower().endswith("position"):
                    root[:, "XYZ".index(c[0].upper())] = block[:, j]
    return SourceMotion(name=_clip_name(path), source=f"BVH {Path(path).name}", fps=1.0 / frame_time, names=names,
                        parents=np.array(parents), rest_positions=rest, local_rotations=local, root_positions=root)


def load_bvh(path, body=None, joint_map=None, **kw):
    body = body or BodyModel.load()
    src = read_bvh(path)
    return retarget(src, joint_map or guess_joint_map(src.names), body, **kw)


# ---- Acclaim ASF/AMC ---------------------------------------------------------------------------------------------
def read_asf(path):
    lines = [ln.split("#")[0].strip() for ln in Path(path).read_text().splitlines()]
    lines = [ln for ln in lines if ln]
    bones = {"root": dict(direction=np.zeros(3), length=0.0, axis=np.zeros(3), axis_order="XYZ", dof=[])}
    order_root, axis_root = ["TX", "TY", "TZ", "RX", "RY", "RZ"], "XYZ"
    hierarchy = {}
    section, cur = None, None
    for ln in lines:
        if ln.startswith(":"):
            section = ln.split()[0][1:]
            rest = ln.split()[1:]
            continue
        parts = ln.split()
        if section == "root":
            if parts[0] == "order":
                order_root = [p.upper() for p in parts[1:]]
            elif parts[0] == "axis":
                axis_root = parts[1].upper()
                bones["root"]["axis_order"] = axis_root
            elif parts[0] == "orientation":
                bones["root"]["axis"] = np.array([float(x) for x in parts[1:4]])
        elif section == "bonedata":
            if parts[0] == "begin":
                cur = dict(direction=np.zeros(3), length=0.0, axis=np.zeros(3), axis_order="XYZ", dof=[])
            elif parts[0] == "end":
                bones[cur["name"]] = cur
            elif parts[0] == "name":
                cur["name"] = parts[1]
            elif parts[0] == "direction":
                cur["direction"] = np.array([float(x) for x in parts[1:4]])
            elif parts[0] == "length":
                cur["length"] = float(parts[1])
            elif parts[0] == "axis":
                cur["axis"] = np.array([float(x) for x in parts[1:4]])
                cur["axis_order"] = parts[4].upper() if len(parts) > 4 else "XYZ"
            elif parts[0] == "dof":
                cur["dof"] = [p.lower() for p in parts[1:]]
        elif section == "hierarchy":
            if parts[0] in ("begin", "end"):
                continue
            for child in parts[1:]:
                hierarchy[child] = parts[0]
    return bones, hierarchy, order_root


def read_amc(path, asf_path=None):
    path = Path(path)
    asf_path = Path(asf_path) if asf_path else path.with_suffix(".asf")
    if not asf_path.is_file():
        raise FileNotFoundError(f"{path}: no ASF skeleton {asf_path.name} beside it")
    bones, hierarchy, order_root = read_asf(asf_path)
    # bones in hierarchy order (parents first)
    names = ["root"]
    while True:
        added = [c for c, p in hierarchy.items() if p in names and c not in names]
        if not added:
            break
        names += added
    idx = {n: i for i, n in enumerate(names)}
    parents = np.array([-1] + [idx[hierarchy[n]] for n in names[1:]])
    # a bone rotates about its start (= the end of its parent): rest position of "joint" b is its start
    ends = np.zeros((len(names), 3))
    rest = np.zeros((len(names), 3))
    for i, n in enumerate(names):
        if i:
            rest[i] = ends[parents[i]]
            b = bones[n]
            ends[i] = rest[i] + b["direction"] / max(np.linalg.norm(b["direction"]), 1e-12) * b["length"]
    frames = []
    for ln in path.read_text().splitlines():
        ln = ln.strip()
        if not ln or ln.startswith(("#", ":")):
            continue
        parts = ln.split()
        if len(parts) == 1 and parts[0].isdigit():
            frames.append({})
        elif frames:
            frames[-1][parts[0]] = np.array([float(x) for x in parts[1:]])
    T = len(frames)
    local = np.broadcast_to(np.eye(3), (T, len(names), 3, 3)).copy()
    root = np.zeros((T, 3))
    for i, n in enumerate(names):
        b = bones[n]
        C = _euler(b["axis_order"], b["axis"], intrinsic=False)
        if n == "root":
            vals = np.stack([f.get("root", np.zeros(len(order_root))) for f in frames])
            rot_axes = "".join(o[1] for o in order_root if o.startswith("R"))
            rot_cols = [j for j, o in enumerate(order_root) if o.startswith("R")]
            for j, o in enumerate(order_root):
                if o.startswith("T"):
                    root[:, "XYZ".index(o[1])] = vals[:, j]
            M = _euler(rot_axes, vals[:, rot_cols], intrinsic=False)
        else:
            dofs = [d for d in b["dof"] if d.startswith("r")]
            if not dofs:
                continue
            vals = np.stack([f.get(n, np.zeros(len(b["dof"])))[[b["dof"].index(d) for d in dofs]] for f in frames])
            M = _euler("".join(d[1] for d in dofs), vals, intrinsic=False)
        local[:, i] = C @ M @ C.T
    return SourceMotion(name=_clip_name(path), source=f"ASF/AMC {asf_path.name} + {path.name}", fps=120.0,
                        names=names, parents=parents, rest_positions=rest, local_rotations=local, root_positions=root)


def load_asf_amc(path, body=None, fps=120.0, joint_map=None, **kw):
    """An .amc file with the .asf of the same stem beside it. Acclaim files carry no frame rate: `fps` (CMU: 120)."""
    body = body or BodyModel.load()
    src = read_amc(path)
    src.fps = float(fps)
    return retarget(src, joint_map or guess_joint_map(src.names), body, **kw)


# ---- AMASS (SMPL-H npz) ------------------------------------------------------------------------------------------
Z_UP_TO_Y_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def read_amass(path, body):
    """SMPL-H `poses` [T,156] axis-angle (root, 21 body joints, 2×15 hand joints), `trans` [T,3] (Z up),
    `mocap_framerate` → SourceMotion on the SMPL joint layout. SMPL's rest is a T-pose: the source rest skeleton
    is the Pleat body's own J(0) with the arms made horizontal, so only the arms get a rest offset."""
    with np.load(path, allow_pickle=False) as z:
        poses = np.asarray(z["poses"], dtype=np.float64)
        trans = np.asarray(z["trans"], dtype=np.float64)
        fps = float(z["mocap_framerate"]) if "mocap_framerate" in z.files else float(z["mocap_frame_rate"])
    if poses.ndim != 2 or poses.shape[1] < 66:
        raise ValueError(f"{path}: poses must be [T, 156] (or at least 66) axis-angle values")
    T = poses.shape[0]
    local = np.broadcast_to(np.eye(3), (T, 24, 3, 3)).copy()
    local[:, :22] = axis_angle_to_matrix(poses[:, :66].reshape(T, 22, 3))    # hands (22, 23) stay identity
    local[:, 0] = Z_UP_TO_Y_UP @ local[:, 0]
    names = list(SMPL_JOINT_NAMES)
    rest = body.joints().copy()
    for side, sx in (("left", 1.0), ("right", -1.0)):
        chain = [names.index(f"{side}_{j}") for j in ("shoulder", "elbow", "wrist", "hand")]
        for a, b in zip(chain[:-1], chain[1:]):
            length = np.linalg.norm(body.joints()[b] - body.joints()[a])
            rest[b] = rest[a] + np.array([sx * length, 0.0, 0.0])
    return SourceMotion(name=_clip_name(path), source=f"AMASS {Path(path).name}", fps=fps, names=names,
                        parents=np.array(SMPL_PARENTS), rest_positions=rest, local_rotations=local,
                        root_positions=trans @ Z_UP_TO_Y_UP.T)


def load_amass(path, body=None, **kw):
    body = body or BodyModel.load()
    kw.setdefault("root_scale", 1.0)   # AMASS is in metres on human-sized SMPL bodies
    return retarget(read_amass(path, body), {n: n for n in SMPL_JOINT_NAMES}, body, **kw)
