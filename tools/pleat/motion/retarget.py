"""Retargeting a source skeleton's motion onto the Pleat body (docs/motion.md).

A `SourceMotion` is any mocap skeleton whose rest pose has identity world rotations (DeepMimic, BVH, ASF/AMC and
SMPL all do): names, parents, rest joint positions, per-frame local rotations and root positions. Retargeting
copies *global* segment orientations: for each body joint k mapped to a source joint s(k),

    G_k = C · W_s(k) · C⁻¹ · O_k

where W is the source's world rotation, C the yaw that turns the source's rest facing to +Z, and O_k the rest
offset: the smallest rotation taking the body's rest bone direction (joint k → its child) onto the source's rest
bone direction, used on the limbs (hips, knees, shoulders, elbows) where the rest poses differ (DeepMimic stands
with arms down, SMPL in a T-pose, the Pleat body in a wide A-pose). An unmapped body joint moves with its parent
(local rotation identity); `spread` shares one joint's local rotation equally over a chain (DeepMimic's single
chest joint over spine1..3). The root path is scaled by the ratio of leg lengths, and a constant height offset puts
the body's lowest point on the ground y = 0 (the 5th percentile over the clip of the per-frame lowest vertex of the
mean body).
"""
from dataclasses import dataclass

import numpy as np

from pleat.body.model import BodyModel
from pleat.motion.clip import Clip, _canonical
from pleat.rotations import matrix_to_quat, quat_slerp, quat_to_matrix, rotation_between, yaw_matrix

LIMB_CHILD = {"left_hip": "left_knee", "right_hip": "right_knee", "left_knee": "left_ankle",
              "right_knee": "right_ankle", "left_shoulder": "left_elbow", "right_shoulder": "right_elbow",
              "left_elbow": "left_wrist", "right_elbow": "right_wrist"}


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

    def world_rotations(self):
        W = np.empty_like(self.local_rotations)
        for s, p in enumerate(self.parents):
            W[:, s] = self.local_rotations[:, s] if p < 0 else W[:, p] @ self.local_rotations[:, s]
        return W


def _leg_length(pos, hip, knee, ankle):
    return float(np.linalg.norm(pos[knee] - pos[hip]) + np.linalg.norm(pos[ankle] - pos[knee]))


def retarget(src, mapping, body, spread=None, root_scale=None, ground=True, beta=None):
    """src: SourceMotion; mapping: {body joint name: source joint name}; body: BodyModel → Clip."""
    names = list(body.joint_names)
    sidx = {n: i for i, n in enumerate(src.names)}
    for k, s in mapping.items():
        if k not in names or s not in sidx:
            raise ValueError(f"bad joint map entry {k} → {s}")
    if mapping.get("pelvis") != src.names[0]:
        raise ValueError("the body's pelvis must map to the source root")
    rest = np.asarray(src.rest_positions, dtype=np.float64)
    # rest facing of the source: left = left hip − right hip, forward = left × up
    left = rest[sidx[mapping["left_hip"]]] - rest[sidx[mapping["right_hip"]]]
    fwd = np.cross(left, [0.0, 1.0, 0.0])
    yaw = np.arctan2(fwd[0], fwd[2])
    C = yaw_matrix(-yaw)                                   # source rest facing → +Z
    W = C @ src.world_rotations() @ C.T                     # [T, S, 3, 3]
    rest = rest @ C.T
    root = np.asarray(src.root_positions, dtype=np.float64) @ C.T
    J = body.joints(beta)
    children = {}
    for s, p in enumerate(src.parents):
        children.setdefault(int(p), []).append(s)

    offsets = {}
    for k, c in LIMB_CHILD.items():
        if k not in mapping:
            continue
        s = sidx[mapping[k]]
        if c in mapping:
            sc = sidx[mapping[c]]
        elif len(children.get(s, [])) == 1:
            sc = children[s][0]
        else:
            continue
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
