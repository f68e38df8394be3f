"""`Clip`: a motion on the Pleat body's 24 joints, and the operations on it (resampling, mirroring, time scaling,
concatenation with blended transitions, root-path variation, pose noise). Quaternions are (x, y, z, w); +Y up
(docs/inputs.md).

A clip holds, per frame t: local joint rotations R_k (quaternions, [T, 24, 4], body joint order, the pelvis's own
R_0 included), the root translation t_root [T, 3] and root rotation Q_root [T, 4] of docs/inputs.md's forward
kinematics. Frames are uniformly spaced at `fps`; the duration is (T − 1) / fps.
"""
from dataclasses import dataclass, field, replace

import numpy as np

from pleat.body.model import SMPL_JOINT_NAMES
from pleat.fileio import save_npz
from pleat.rotations import axis_angle_to_quat, quat_continuous, quat_multiply, quat_normalize, quat_slerp, \
    quat_to_axis_angle, quat_to_matrix, yaw_of, yaw_matrix, matrix_to_quat

POSE_NOISE_KNOTS_PER_S = 2.0     # Clip.with_pose_noise: a new random offset every half second


def _mirror_index(names):
    out = []
    for n in names:
        if n.startswith("left_"):
            out.append(names.index("right_" + n[5:]))
        elif n.startswith("right_"):
            out.append(names.index("left_" + n[6:]))
        else:
            out.append(names.index(n))
    return np.array(out)


def _yaw_quat(yaw):
    yaw = np.asarray(yaw, dtype=np.float64)
    return np.stack([np.zeros_like(yaw), np.sin(yaw / 2), np.zeros_like(yaw), np.cos(yaw / 2)], axis=-1)


def _quat_power(q, t):
    """q^t (x, y, z, w): the same axis, t times the angle, the shorter way round."""
    q = quat_normalize(q)
    q = np.where(q[..., 3:4] < 0, -q, q)
    angle = 2.0 * np.arccos(np.clip(q[..., 3], -1.0, 1.0))
    s = np.sin(angle / 2.0)
    axis = np.where(s[..., None] > 1e-9, q[..., :3] / np.maximum(s, 1e-12)[..., None], np.array([1.0, 0.0, 0.0]))
    half = angle * t / 2.0
    return np.concatenate([axis * np.sin(half)[..., None], np.cos(half)[..., None]], -1)


def _canonical(q):
    """Quaternions with w >= 0 (q and −q are the same rotation)."""
    return np.where(q[..., 3:4] < 0, -q, q)


def _smooth_offsets(rng, times, joints, amplitude_rad, knots_per_s):
    """Random rotation vectors [T, joints, 3] (rad) that wander slowly: drawn uniformly in the ball of radius
    `amplitude_rad` at knots 1/knots_per_s s apart, smoothstep-interpolated between them. Each frame's offset is a
    convex combination of two knots, so it stays in the ball; the curve's slope is zero at every knot, so it has no
    kink there (a kink is a jolt the simulated cloth would answer)."""
    knot_count = int(np.floor(times[-1] * knots_per_s)) + 2
    direction = rng.normal(size=(knot_count, joints, 3))
    direction /= np.linalg.norm(direction, axis=-1, keepdims=True)
    radius = amplitude_rad * np.cbrt(rng.uniform(size=(knot_count, joints, 1)))
    knots = direction * radius
    x = times * knots_per_s
    i = np.minimum(np.floor(x).astype(np.int64), knot_count - 2)
    u = x - i
    w = (u * u * (3 - 2 * u))[:, None, None]
    return knots[i] * (1 - w) + knots[i + 1] * w


@dataclass
class Clip:
    name: str
    fps: float
    local_rotations: np.ndarray          # [T, J, 4] (x, y, z, w)
    root_translation: np.ndarray         # [T, 3] metres
    root_rotation: np.ndarray            # [T, 4] (x, y, z, w)
    source: str = ""
    joint_names: tuple = field(default=SMPL_JOINT_NAMES)

    def __post_init__(self):
        self.local_rotations = np.asarray(self.local_rotations, dtype=np.float64)
        self.root_translation = np.asarray(self.root_translation, dtype=np.float64)
        self.root_rotation = np.asarray(self.root_rotation, dtype=np.float64)
        self.joint_names = tuple(self.joint_names)
        T = self.local_rotations.shape[0]
        if self.local_rotations.shape != (T, len(self.joint_names), 4):
            raise ValueError(f"local_rotations must be [T, {len(self.joint_names)}, 4], got "
                             f"{self.local_rotations.shape}")
        if self.root_translation.shape != (T, 3) or self.root_rotation.shape != (T, 4):
            raise ValueError("root_translation must be [T, 3] and root_rotation [T, 4]")
        if not self.fps > 0:
            raise ValueError("fps must be positive")

    @property
    def num_frames(self):
        return self.local_rotations.shape[0]

    @property
    def duration(self):
        return (self.num_frames - 1) / self.fps

    @property
    def times(self):
        return np.arange(self.num_frames) / self.fps

    def frames_at(self, index, name=None):
        """The clip's frames at `index` (a slice or integer frame numbers, repeats allowed), in that order, at the
        same fps: a cut, a loop or a hold without touching the pose arrays by hand."""
        return replace(self, name=self.name if name is None else name, local_rotations=self.local_rotations[index],
                       root_translation=self.root_translation[index], root_rotation=self.root_rotation[index])

    def local_matrices(self):
        return quat_to_matrix(self.local_rotations)

    def root_matrices(self):
        return quat_to_matrix(self.root_rotation)

    def pelvis_positions(self, body=None, beta=None):
        """World pelvis position per frame: t_root + Q_root · J_0(β)."""
        if body is None:
            return self.root_translation.copy()
        j0 = body.joints(beta)[..., 0, :]
        return self.root_translation + np.einsum("tij,...j->t...i", self.root_matrices(), j0)

    def skin(self, body, beta=None, frames=None):
        sel = slice(None) if frames is None else frames
        return body.skin(self.local_matrices()[sel], self.root_translation[sel], self.root_matrices()[sel], beta)

    def joint_positions(self, body, beta=None):
        G = body.forward_kinematics(self.local_matrices(), self.root_translation, self.root_matrices(), beta)
        return G[..., :3, 3]

    # ---- storage ------------------------------------------------------------------------------------------------
    def save(self, path):
        """Writes the npz atomically (pleat.fileio: a failed write keeps the old file); adds .npz like numpy."""
        return save_npz(path, compressed=True, name=np.array(self.name), source=np.array(self.source),
                            fps=np.float64(self.fps), joint_names=np.array(self.joint_names),
                            local_rotations=self.local_rotations.astype(np.float32),
                            root_translation=self.root_translation.astype(np.float32),
                            root_rotation=self.root_rotation.astype(np.float32))

    @classmethod
    def load(cls, path):
        with np.load(path, allow_pickle=False) as z:
            return cls(name=str(z["name"]), fps=float(z["fps"]), local_rotations=quat_normalize(z["local_rotations"]),
                       root_translation=z["root_translation"], root_rotation=quat_normalize(z["root_rotation"]),
                       source=str(z["source"]), joint_names=[str(n) for n in z["joint_names"]])

    # ---- operations ---------------------------------------------------------------------------------------------
    def sample(self, t):
        """Rotations slerped and translations lerped at times t [N] (seconds, clamped to the clip)."""
        t = np.clip(np.asarray(t, dtype=np.float64), 0.0, self.duration)
        x = t * self.fps
        i0 = np.minimum(np.floor(x).astype(np.int64), self.num_frames - 1)
        i1 = np.minimum(i0 + 1, self.num_frames - 1)
        a = x - i0
        rot = quat_slerp(self.local_rotations[i0], self.local_rotations[i1], np.broadcast_to(a[:, None], i0.shape + (
            len(self.joint_names),)))
        root_rot = quat_slerp(self.root_rotation[i0], self.root_rotation[i1], a)
        trans = self.root_translation[i0] * (1 - a[:, None]) + self.root_translation[i1] * a[:, None]
        return rot, trans, root_rot

    def resample(self, fps):
        """Same motion at `fps` (slerp); the duration is kept to within half a frame of the new rate."""
        n = int(round(self.duration * fps)) + 1
        rot, trans, root_rot = self.sample(np.arange(n) / fps)
        return replace(self, fps=float(fps), local_rotations=rot, root_translation=trans, root_rotation=root_rot)

    def time_scaled(self, factor):
        """Played `factor` times faster (factor < 1: slower), same fps; the path is the same."""
        if not factor > 0:
            raise ValueError("factor must be positive")
        n = int(round(self.duration / factor * self.fps)) + 1
        rot, trans, root_rot = self.sample(np.arange(n) / self.fps * factor)
        return replace(self, name=f"{self.name}@x{factor:g}", local_rotations=rot, root_translation=trans,
                       root_rotation=root_rot)

    def mirrored(self):
        """Left-right mirror through the body's sagittal plane x = 0: x ↦ −x for positions, a rotation
        (x, y, z, w) ↦ (x, −y, −z, w), and left/right joints swapped. Mirroring twice gives the clip back."""
        flip = np.array([1.0, -1.0, -1.0, 1.0])
        idx = _mirror_index(list(self.joint_names))
        name = self.name[:-7] if self.name.endswith("@mirror") else self.name + "@mirror"
        return replace(self, name=name, local_rotations=self.local_rotations[:, idx] * flip,
                       root_translation=self.root_translation * np.array([-1.0, 1.0, 1.0]),
                       root_rotation=self.root_rotation * flip)

    def with_collar_share(self, share):
        """Each shoulder's rotation with `share` of its angle moved into its collar (same axis): the arm keeps its
        orientation relative to the chest and the shoulder joint moves with the collar, as with a skeleton that has
        clavicles. The training motion (DeepMimic) has none — its collars are always the identity — so a model
        trained on it alone meets collar rotations first in a user's motion (docs/accuracy.md); the simulator-
        supervised recipe's "collar" variant (pleat.train.simdata) trains on this."""
        names = list(self.joint_names)
        q = self.local_rotations.copy()
        for side in ("left", "right"):
            c, sh = names.index(f"{side}_collar"), names.index(f"{side}_shoulder")
            part = _quat_power(q[:, sh], share)
            q[:, c] = quat_multiply(q[:, c], part)
            q[:, sh] = quat_multiply(part * np.array([-1.0, -1.0, -1.0, 1.0]), q[:, sh])
        return replace(self, name=f"{self.name}@collar{share:g}", local_rotations=q)

    def with_holds(self, move, hold):
        """Sudden stops and starts: the clip cut into pieces of `move` frames (at most half the clip, so that there
        are at least two), each followed by its last pose, root included, held for `hold` frames; then the next piece
        starts from rest. The path and every pose are the clip's own: only the timing changes. A clip that loops,
        as most training clips do, never stops dead, and a model that never saw the body stop has not learnt how
        cloth swings on after it (docs/accuracy.md, "Sudden stops"); the simulator-supervised recipe's "stop"
        variant (pleat.train.simdata) trains on this."""
        T = self.num_frames
        move = max(1, min(int(move), T // 2 or 1))
        idx = []
        for start in range(0, T, move):
            piece = list(range(start, min(start + move, T)))
            idx += piece + [piece[-1]] * int(hold)
        idx = np.asarray(idx, np.int64)
        return self.frames_at(idx, name=f"{self.name}@hold{move}+{int(hold)}")

    def joint_rotation_vectors(self):
        """Each joint's local rotation as an axis-angle vector [T, J, 3] (rad), continuous over the clip (the
        quaternions are kept on one hemisphere, so a joint turning through a half turn does not jump)."""
        return quat_to_axis_angle(quat_continuous(self.local_rotations))

    def joint_rotation_range(self, margin_rad=0.0):
        """(lo, hi) [J, 3]: per joint and axis, the range of joint_rotation_vectors over the clip, widened by
        `margin_rad` each way — the joint limits the clip itself shows."""
        r = self.joint_rotation_vectors()
        return r.min(axis=0) - margin_rad, r.max(axis=0) + margin_rad

    def with_pose_noise(self, amplitude_rad, seed, limits=None, knots_per_s=POSE_NOISE_KNOTS_PER_S):
        """Pose noise within joint limits: every joint's local rotation vector but the pelvis's (R_0 turns the whole
        body, so it belongs to the root, which is left as it is) plus a smooth random offset of at most
        `amplitude_rad` (_smooth_offsets: a new one every 1/knots_per_s s), clamped per axis to `limits` (lo, hi)
        [J, 3] on joint_rotation_vectors. The default limits are the clip's own range widened by half the amplitude:
        the repository has no joint-limit tables, and limits from the clip alone make the noisy clip a function of
        the clip and the seed only (no other clip can change it). With limits that hold the clip's own poses (the
        default's do), the clamp only pulls toward them, so each joint turns at most `amplitude_rad` away from its
        pose. The same seed gives the same clip. The simulator-supervised recipe's "noise" variant
        (pleat.train.simdata) trains on this: poses near, not on, the training motion's."""
        r = self.joint_rotation_vectors()
        lo, hi = self.joint_rotation_range(amplitude_rad / 2) if limits is None else limits
        offsets = _smooth_offsets(np.random.default_rng(seed), self.times, len(self.joint_names), amplitude_rad,
                                  knots_per_s)
        q = axis_angle_to_quat(np.clip(r + offsets, lo, hi))
        q[:, 0] = self.local_rotations[:, 0]
        return replace(self, name=f"{self.name}@noise{amplitude_rad:g}/{seed}", local_rotations=q)

    def heading(self):
        """Yaw (rad) of the pelvis's global rotation Q_root · R_0 per frame (docs/inputs.md)."""
        P = self.root_matrices() @ quat_to_matrix(self.local_rotations[:, 0])
        yaw, _ = yaw_of(P)
        return yaw

    def with_root_path(self, yaw_offset=0.0, turn_rate=0.0, origin=None):
        """Root-path variation: the clip turned by `yaw_offset` (rad) about +Y and bent by a constant extra turn
        rate (rad/s): the horizontal root velocity and the root rotation are rotated by yaw_offset + turn_rate·t.
        The path starts at `origin` (xz; default: where it started)."""
        t = self.times
        theta = yaw_offset + turn_rate * t
        start = self.root_translation[0].copy()
        vel = np.diff(self.root_translation, axis=0)
        mid = 0.5 * (theta[1:] + theta[:-1])
        vel_r = np.einsum("tij,tj->ti", yaw_matrix(mid), vel)
        trans = np.concatenate([start[None], start + np.cumsum(vel_r, axis=0)], axis=0)
        if origin is not None:
            trans[:, [0, 2]] += np.asarray(origin, dtype=np.float64) - trans[0, [0, 2]]
        trans[:, 1] = self.root_translation[:, 1]
        root_rot = _canonical(quat_multiply(_yaw_quat(theta), self.root_rotation))
        return replace(self, name=f"{self.name}@path({yaw_offset:.2f},{turn_rate:.2f})", root_translation=trans,
                       root_rotation=root_rot)


def crossfade_frames(a, b, blend_s=0.25):
    """How many frames concatenate(a, b, blend_s) cross-fades: the last ones of a, laid over b's first. The
    concatenation has a.num_frames + b.num_frames − n frames (b at a's fps), the cross-fade at [a.num_frames − n,
    a.num_frames)."""
    b_frames = b.num_frames if abs(a.fps - b.fps) <= 1e-9 else int(round(b.duration * a.fps)) + 1
    return max(1, min(int(round(blend_s * a.fps)), a.num_frames - 1, b_frames - 1))


def concatenate(a, b, blend_s=0.25):
    """a then b, b turned and moved so that it starts where and facing where a ends, with a `blend_s` cross-fade
    (smoothstep slerp over the overlapping frames). b is resampled to a's fps if needed."""
    if abs(a.fps - b.fps) > 1e-9:
        b = b.resample(a.fps)
    n = crossfade_frames(a, b, blend_s)
    # b's first frame is laid over a's frame −n: align heading and horizontal position there
    ya, yb = a.heading()[-n], b.heading()[0]
    b = b.with_root_path(yaw_offset=ya - yb)
    shift = a.root_translation[-n, [0, 2]] - b.root_translation[0, [0, 2]]
    b_trans = b.root_translation.copy()
    b_trans[:, [0, 2]] += shift
    b = replace(b, root_translation=b_trans)
    s = (np.arange(n) + 1) / (n + 1)
    w = s * s * (3 - 2 * s)
    rot = quat_slerp(a.local_rotations[-n:], b.local_rotations[:n], np.broadcast_to(w[:, None], (n, len(a.joint_names))))
    root_rot = quat_slerp(a.root_rotation[-n:], b.root_rotation[:n], w)
    trans = a.root_translation[-n:] * (1 - w[:, None]) + b.root_translation[:n] * w[:, None]
    return Clip(name=f"{a.name}+{b.name}", fps=a.fps,
                local_rotations=np.concatenate([a.local_rotations[:-n], rot, b.local_rotations[n:]]),
                root_translation=np.concatenate([a.root_translation[:-n], trans, b.root_translation[n:]]),
                root_rotation=np.concatenate([a.root_rotation[:-n], root_rot, b.root_rotation[n:]]),
                source=f"concatenation of [{a.source}] and [{b.source}]", joint_names=a.joint_names)


def identity_clip(num_frames, fps=30.0, name="rest", joint_names=SMPL_JOINT_NAMES):
    q = np.zeros((num_frames, len(joint_names), 4))
    q[..., 3] = 1
    r = np.zeros((num_frames, 4))
    r[:, 3] = 1
    return Clip(name=name, fps=fps, local_rotations=q, root_translation=np.zeros((num_frames, 3)), root_rotation=r,
                joint_names=joint_names)


__all__ = ["Clip", "concatenate", "crossfade_frames", "identity_clip", "matrix_to_quat"]
