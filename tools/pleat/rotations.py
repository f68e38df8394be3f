"""Rotation helpers shared by the body, motion, reference and training code.

Conventions (docs/inputs.md): quaternions are (x, y, z, w); matrices act on column vectors; +Y is up.
Every function takes arrays with arbitrary leading dimensions.
"""
import numpy as np


def quat_normalize(q):
    q = np.asarray(q, dtype=np.float64)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def quat_multiply(a, b):
    """Hamilton product a·b (apply b first, then a)."""
    ax, ay, az, aw = np.moveaxis(np.asarray(a, dtype=np.float64), -1, 0)
    bx, by, bz, bw = np.moveaxis(np.asarray(b, dtype=np.float64), -1, 0)
    return np.stack([
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ], axis=-1)


def quat_to_matrix(q):
    x, y, z, w = np.moveaxis(quat_normalize(q), -1, 0)
    m = np.empty(np.shape(x) + (3, 3))
    m[..., 0, 0] = 1 - 2 * (y * y + z * z)
    m[..., 0, 1] = 2 * (x * y - z * w)
    m[..., 0, 2] = 2 * (x * z + y * w)
    m[..., 1, 0] = 2 * (x * y + z * w)
    m[..., 1, 1] = 1 - 2 * (x * x + z * z)
    m[..., 1, 2] = 2 * (y * z - x * w)
    m[..., 2, 0] = 2 * (x * z - y * w)
    m[..., 2, 1] = 2 * (y * z + x * w)
    m[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return m


def matrix_to_quat(m):
    """Rotation matrix → unit quaternion (x, y, z, w) with w >= 0."""
    m = np.asarray(m, dtype=np.float64)
    trace = m[..., 0, 0] + m[..., 1, 1] + m[..., 2, 2]
    # Pick the numerically largest of 4w², 4x², 4y², 4z² per rotation (Shepperd's method).
    cand = np.stack([1 + trace,
                     1 + m[..., 0, 0] - m[..., 1, 1] - m[..., 2, 2],
                     1 - m[..., 0, 0] + m[..., 1, 1] - m[..., 2, 2],
                     1 - m[..., 0, 0] - m[..., 1, 1] + m[..., 2, 2]], axis=-1)
    best = np.argmax(cand, axis=-1)
    s = np.sqrt(np.maximum(np.take_along_axis(cand, best[..., None], -1)[..., 0], 1e-300)) * 2
    q = np.empty(m.shape[:-2] + (4,))
    r21, r12 = m[..., 2, 1], m[..., 1, 2]
    r02, r20 = m[..., 0, 2], m[..., 2, 0]
    r10, r01 = m[..., 1, 0], m[..., 0, 1]
    qw = np.stack([s / 4, (r21 - r12) / s, (r02 - r20) / s, (r10 - r01) / s], -1)
    qx = np.stack([(r21 - r12) / s, s / 4, (r01 + r10) / s, (r02 + r20) / s], -1)
    qy = np.stack([(r02 - r20) / s, (r01 + r10) / s, s / 4, (r12 + r21) / s], -1)
    qz = np.stack([(r10 - r01) / s, (r02 + r20) / s, (r12 + r21) / s, s / 4], -1)
    # columns of the candidates are (w, x, y, z)
    table = np.stack([qw, qx, qy, qz], axis=-2)
    wxyz = np.take_along_axis(table, best[..., None, None], -2)[..., 0, :]
    q[..., 3], q[..., 0], q[..., 1], q[..., 2] = wxyz[..., 0], wxyz[..., 1], wxyz[..., 2], wxyz[..., 3]
    q = np.where(q[..., 3:4] < 0, -q, q)
    return quat_normalize(q)


def axis_angle_to_quat(aa):
    """Axis-angle vectors (..., 3) → unit quaternions (x, y, z, w); the angle is the vector's length."""
    aa = np.asarray(aa, dtype=np.float64)
    angle = np.linalg.norm(aa, axis=-1, keepdims=True)
    half = angle / 2
    small = angle < 1e-12
    # sin(half)/angle → 1/2 as angle → 0
    scale = np.where(small, 0.5, np.sin(half) / np.where(small, 1.0, angle))
    return np.concatenate([aa * scale, np.cos(half)], axis=-1)


def quat_continuous(q):
    """Quaternions (x, y, z, w) [T, ...] signed frame by frame to lie nearest the previous frame's (q and −q are one
    rotation), the first frame with w >= 0: axis-angle vectors (quat_to_axis_angle) and keyframe curves between
    frames then change continuously, the short way."""
    q = np.asarray(q, np.float64)
    flips = np.where(np.sum(q[1:] * q[:-1], axis=-1) < 0, -1.0, 1.0)
    sign = np.cumprod(np.concatenate([np.where(q[:1, ..., 3] < 0, -1.0, 1.0), flips]), axis=0)
    return q * sign[..., None]


def quat_to_axis_angle(q):
    """Unit quaternions (x, y, z, w) → axis-angle vectors (..., 3), the inverse of axis_angle_to_quat. The angle is
    2·atan2(|xyz|, w) in [0, 2π]: q and −q give the two vectors of one rotation (angles θ and 2π − θ), so a sequence
    kept on one hemisphere has vectors that change continuously, through half turns too."""
    q = quat_normalize(q)
    sin_half = np.linalg.norm(q[..., :3], axis=-1, keepdims=True)
    angle = 2 * np.arctan2(sin_half, q[..., 3:4])
    small = sin_half < 1e-12
    # angle/sin(half) → 2/w as sin(half) → 0
    scale = np.where(small, 2.0 / np.where(small, q[..., 3:4], 1.0), angle / np.where(small, 1.0, sin_half))
    return q[..., :3] * scale


def axis_angle_to_matrix(aa):
    """Rodrigues: axis-angle vectors (..., 3) → (..., 3, 3)."""
    return quat_to_matrix(axis_angle_to_quat(aa))


def rotation_between(a, b):
    """Smallest rotation taking direction a to direction b (arrays [..., 3], any length) → [..., 3, 3]. Opposite
    directions (no unique smallest rotation) get the half turn about an axis perpendicular to a."""
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    v = np.cross(a, b)
    c = np.sum(a * b, axis=-1)[..., None, None]
    vx = np.zeros(v.shape[:-1] + (3, 3))
    vx[..., 0, 1], vx[..., 0, 2], vx[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    vx = vx - np.swapaxes(vx, -1, -2)
    opposite = c < -1 + 1e-9
    smallest = np.eye(3) + vx + vx @ vx / np.where(opposite, 1.0, 1.0 + c)
    axis = np.cross(a, [1.0, 0.0, 0.0])
    axis = np.where(np.linalg.norm(axis, axis=-1, keepdims=True) < 1e-6, np.cross(a, [0.0, 1.0, 0.0]), axis)
    axis = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    half_turn = 2 * axis[..., :, None] * axis[..., None, :] - np.eye(3)
    return np.where(opposite, half_turn, smallest)


def matrix_to_6d(m):
    """First two columns, column by column: (R00, R10, R20, R01, R11, R21) — Zhou et al. 2019."""
    m = np.asarray(m)
    return np.concatenate([m[..., :, 0], m[..., :, 1]], axis=-1)


def sixd_to_matrix(d6):
    """Gram–Schmidt inverse of matrix_to_6d."""
    d6 = np.asarray(d6, dtype=np.float64)
    a, b = d6[..., 0:3], d6[..., 3:6]
    c0 = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b - np.sum(c0 * b, axis=-1, keepdims=True) * c0
    c1 = b / np.linalg.norm(b, axis=-1, keepdims=True)
    c2 = np.cross(c0, c1)
    return np.stack([c0, c1, c2], axis=-1)


def yaw_of(m):
    """Yaw angle about +Y of rotation matrices: the heading of the rotated +Z axis (docs/inputs.md).

    Returns (yaw, valid); valid is False where the forward axis is (nearly) vertical."""
    m = np.asarray(m, dtype=np.float64)
    fx, fz = m[..., 0, 2], m[..., 2, 2]
    valid = np.hypot(fx, fz) > 1e-6
    return np.arctan2(fx, fz), valid


def yaw_matrix(yaw):
    yaw = np.asarray(yaw, dtype=np.float64)
    c, s = np.cos(yaw), np.sin(yaw)
    m = np.zeros(yaw.shape + (3, 3))
    m[..., 0, 0], m[..., 0, 2] = c, s
    m[..., 1, 1] = 1.0
    m[..., 2, 0], m[..., 2, 2] = -s, c
    return m


def wrap_angle(a):
    """Wrap to (−π, π]."""
    a = np.asarray(a, dtype=np.float64)
    return np.pi - np.mod(np.pi - a, 2 * np.pi)


def quat_slerp(a, b, t):
    a, b = quat_normalize(a), quat_normalize(b)
    dot = np.sum(a * b, axis=-1, keepdims=True)
    b = np.where(dot < 0, -b, b)
    dot = np.abs(dot)
    t = np.asarray(t, dtype=np.float64)[..., None] if np.ndim(t) else t
    theta = np.arccos(np.clip(dot, -1.0, 1.0))
    sin_theta = np.sin(theta)
    near = sin_theta < 1e-6
    wa = np.where(near, 1 - t, np.sin((1 - t) * theta) / np.where(near, 1.0, sin_theta))
    wb = np.where(near, t, np.sin(t * theta) / np.where(near, 1.0, sin_theta))
    return quat_normalize(wa * a + wb * b)
