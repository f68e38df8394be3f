"""Retargeting a source skeleton's motion onto the Pleat body (docs/motion.md).

A `SourceMotion` is any mocap skeleton whose rest pose has identity world rotations (DeepMimic, BVH, ASF/AMC and
SMPL all do): names, parents, rest joint positions, per-frame local rotations and root positions. Retargeting
copies *global* segment orientations: for each body joint k mapped to a source joint s(k),

    G_k = C · W_s(k) · C⁻¹ · O_k

where W is the source's world rotation, C the yaw that turns the source's rest facing to +Z, and O_k the rest
offset: the smallest rotation taking the body's rest bone direction (joint k → its child) onto the source's rest
bone direction. `rest_offsets="all"` (BVH and ASF/AMC skeletons) sets it for every mapped joint but the pelvis and
the head, with the bone running to the nearest mapped joint down the body's chain (BONE_CHILD), so a T-pose, an
A-pose or arms hanging down, a raised clavicle or a leaning spine all come out as the source holds them;
`rest_offsets="limbs"` (the fixed DeepMimic and AMASS skeletons, which the training clips were made with) sets it on
hips, knees, shoulders and elbows only. An unmapped body joint moves with its parent
(local rotation identity); `spread` shares one joint's local rotation equally over a chain (DeepMimic's single
chest joint over spine1..3). The root path is scaled by the ratio of leg lengths, and a constant height offset puts
the body's lowest point on the ground y = 0 (the 5th percentile over the clip of the per-frame lowest vertex of the
mean body).
"""
from dataclasses import dataclass, field

import numpy as np

from pleat.body.model import BodyModel
from pleat.motion.clip import Clip, _canonical
from pleat.rotations import matrix_to_quat, quat_slerp, quat_to_matrix, rotation_between, yaw_matrix

LIMB_CHILD = {"left_hip": "left_knee", "right_hip": "right_knee", "left_knee": "left_ankle",
              "right_knee": "right_ankle", "left_shoulder": "left_elbow", "right_shoulder": "right_elbow",
              "left_elbow": "left_wrist", "right_elbow": "right_wrist"}
# The bone that orients each body joint: its child along the chain (pelvis and head have none that says more than the
# root's facing does; the spine's bone runs to the neck, not to a clavicle).
BONE_CHILD = {"spine1": "spine2", "spine2": "spine3", "spine3": "neck", "neck": "head",
              **{f"{s}_{a}": f"{s}_{b}" for s in ("left", "right") for a, b in (
                  ("hip", "knee"), ("knee", "ankle"), ("ankle", "foot"), ("collar", "shoulder"),
                  ("shoulder", "elbow"), ("elbow", "wrist"), ("wrist", "hand"))}}


@dataclass
class SourceMotion:
    name: str
    source: str
    fps: float
    names: list                  # [S]
    parents: np.ndarray          # [S], parents[0] = -1
    rest_positions: np.ndarray   # [S, 3] world rest positions (source units, +Y up)
    local_rotations: np.ndarray  # [T, S, 3, 3] relative to the parent, rest = identity
    root_positions: np.ndarray   # [T, 3] world position of joint 0 (source units)
    # {joint: [T, 3]} offsets from the parent, in the parent's frame, for joints below the root that have position
    # channels of their own (they replace the rest offset); empty for most skeletons
    joint_translations: dict = field(default_factory=dict)

    def world_rotations(self):
        W = np.empty_like(self.local_rotations)
        for s, p in enumerate(self.parents):
            W[:, s] = self.local_rotations[:, s] if p < 0 else W[:, p] @ self.local_rotations[:, s]
        return W

    def world_positions(self, W=None):
        """Joint positions per frame [T, S, 3] (source units) by forward kinematics of the rest offsets."""
        W = self.world_rotations() if W is None else W
        rest = np.asarray(self.rest_positions, np.float64)
        P = np.empty(W.shape[:2] + (3,))
        for s, p in enumerate(self.parents):
            if p < 0:
                P[:, s] = self.root_positions
            else:
                offset = np.broadcast_to(self.joint_translations.get(s, rest[s] - rest[p]), (len(W), 3))
                P[:, s] = P[:, p] + np.einsum("tij,tj->ti", W[:, p], offset)
        return P


def source_leg_scale(src, mapping, body):
    """Body leg length / source leg length (hip → knee → ankle on the rest skeletons): metres per source unit."""
    names = list(body.joint_names)
    sidx = {n: i for i, n in enumerate(src.names)}
    J = body.joints()
    body_leg = _leg_length(J, names.index("left_hip"), names.index("left_knee"), names.index("left_ankle"))
    src_leg = _leg_length(np.asarray(src.rest_positions, np.float64), sidx[mapping["left_hip"]],
                          sidx[mapping["left_knee"]], sidx[mapping["left_ankle"]])
    return body_leg / src_leg


def _leg_length(pos, hip, knee, ankle):
    return float(np.linalg.norm(pos[knee] - pos[hip]) + np.linalg.norm(pos[ankle] - pos[knee]))


def source_facing(src, mapping):
    """C: the yaw that turns the source's rest facing (forward = left × up, left = left hip − right hip) to +Z."""
    sidx = {n: i for i, n in enumerate(src.names)}
    rest = np.asarray(src.rest_positions, dtype=np.float64)
    left = rest[sidx[mapping["left_hip"]]] - rest[sidx[mapping["right_hip"]]]
    fwd = np.cross(left, [0.0, 1.0, 0.0])
    return yaw_matrix(-np.arctan2(fwd[0], fwd[2]))


def _bone_pairs(src, mapping, body, mode):
    """{body joint k: (body child c, source joint, source end joint)}: the bones whose rest directions are aligned
    (see the module doc)."""
    names = list(body.joint_names)
    sidx = {n: i for i, n in enumerate(src.names)}
    children = {}
    for s, p in enumerate(src.parents):
        children.setdefault(int(p), []).append(s)
    out = {}
    for k, c in (LIMB_CHILD if mode == "limbs" else BONE_CHILD).items():
        if k not in mapping:
            continue
        s = sidx[mapping[k]]
        end = c
        if mode != "limbs":
            # down the body's chain to the first mapped joint (a Biovision spine has no spine1, DeepMimic no wrist)
            while end not in mapping and end in BONE_CHILD:
                end = BONE_CHILD[end]
        if end in mapping:
            out[k] = (end, s, sidx[mapping[end]])
        elif len(children.get(s, [])) == 1:
            out[k] = (c, s, children[s][0])
    return out


def retarget(src, mapping, body, spread=None, root_scale=None, ground=True, beta=None, rest_offsets="limbs"):
    """src: SourceMotion; mapping: {body joint name: source joint name}; body: BodyModel → Clip. rest_offsets:
    "limbs" or "all" (see the module doc)."""
    names = list(body.joint_names)
    sidx = {n: i for i, n in enumerate(src.names)}
    for k, s in mapping.items():
        if k not in names or s not in sidx:
            raise ValueError(f"bad joint map entry {k} → {s}")
    if mapping.get("pelvis") != src.names[0]:
        raise ValueError("the body's pelvis must map to the source root")
    C = source_facing(src, mapping)                        # source rest facing → +Z
    W = C @ src.world_rotations() @ C.T                     # [T, S, 3, 3]
    rest = np.asarray(src.rest_positions, dtype=np.float64) @ C.T
    root = np.asarray(src.root_positions, dtype=np.float64) @ C.T
    J = body.joints(beta)

    offsets = {}
    for k, (c, s, sc) in _bone_pairs(src, mapping, body, rest_offsets).items():
        d_src = rest[sc] - rest[s]
        d_body = J[names.index(c)] - J[names.index(k)]
        if np.linalg.norm(d_src) > 1e-9:
            offsets[k] = rotation_between(d_body, d_src)

    T = W.shape[0]
    G = np.empty((T, len(names), 3, 3))
    for k, n in enumerate(names):
        if n in mapping:
            G[:, k] = W[:, sidx[mapping[n]]] @ offsets.get(n, np.eye(3))
        else:
            G[:, k] = G[:, body.parents[k]]
    R = np.empty_like(G)
    R[:, 0] = np.eye(3)
    for k in range(1, len(names)):
        R[:, k] = np.swapaxes(G[:, body.parents[k]], -1, -2) @ G[:, k]
    q = matrix_to_quat(R)
    for target, chain in (spread or {}).items():
        full = q[:, names.index(target)]
        ident = np.zeros_like(full)
        ident[:, 3] = 1
        part = quat_slerp(ident, full, 1.0 / len(chain))
        for n in chain:
            q[:, names.index(n)] = part
    root_rot = matrix_to_quat(G[:, 0])

    if root_scale is None:
        body_leg = _leg_length(J, names.index("left_hip"), names.index("left_knee"), names.index("left_ankle"))
        src_leg = _leg_length(rest, sidx[mapping["left_hip"]], sidx[mapping["left_knee"]],
                              sidx[mapping["left_ankle"]])
        root_scale = body_leg / src_leg
    trans = root * root_scale - np.einsum("tij,j->ti", G[:, 0], J[0])   # pelvis joint at the scaled source root
    clip = Clip(name=src.name, fps=src.fps, local_rotations=_canonical(q), root_translation=trans,
                root_rotation=_canonical(root_rot), source=src.source, joint_names=names)
    if ground:
        clip = place_on_ground(clip, body, beta)
    return clip


def place_on_ground(clip, body, beta=None, percentile=5.0, max_frames=120, vertex_stride=3):
    """Shift the clip vertically so that the body's lowest point is at y = 0 (the `percentile` of the per-frame
    minimum vertex height, over up to `max_frames` evenly spaced frames; vertices subsampled by `vertex_stride`)."""
    frames = np.unique(np.linspace(0, clip.num_frames - 1, min(max_frames, clip.num_frames)).astype(np.int64))
    lowest = lowest_point_heights(clip, body, beta, frames, vertex_stride)
    trans = clip.root_translation.copy()
    trans[:, 1] -= np.percentile(lowest, percentile)
    return Clip(name=clip.name, fps=clip.fps, local_rotations=clip.local_rotations, root_translation=trans,
                root_rotation=clip.root_rotation, source=clip.source, joint_names=clip.joint_names)


def lowest_point_heights(clip, body, beta=None, frames=None, vertex_stride=3):
    """Per-frame height (y) of the posed body's lowest vertex (subsampled) → [len(frames)]."""
    if frames is None:
        frames = np.arange(clip.num_frames)
    sub = BodyModel(body.v_template[::vertex_stride], np.zeros((1, 3), dtype=np.int64),
                    body.shapedirs[::vertex_stride], np.eye(body.num_joints, body.v_template[::vertex_stride].shape[0]),
                    body.weights[::vertex_stride], body.parents, body.joint_names)
    # the subsampled model's own regressor is a stand-in: joints come from the full body
    sub.J_template, sub.J_shapedirs = body.J_template, body.J_shapedirs
    v = sub.skin(quat_to_matrix(clip.local_rotations[frames]), clip.root_translation[frames],
                 quat_to_matrix(clip.root_rotation[frames]), beta)
    return v[..., 1].min(axis=-1)
