"""A small stand-in body with the BodyModel interface: capsules around a 24-joint SMPL-named T-pose skeleton.

For tests and development when assets/body.npz is absent. The surface is the zero level set of a smooth union of
capsule distance fields, meshed by marching cubes; skinning weights fall off with the distance to each bone;
two shape directions: girth (β0, 1.5 cm outward per unit) and height (β1, 3 % per unit); the other eight are zero.
"""
import numpy as np

from ..body.model import SMPL_JOINT_NAMES, SMPL_PARENTS, BodyModel
from ..reference.normals import face_normals, normals_scatter

_JOINTS = np.array([
    (0.0, 0.95, 0.0), (0.09, 0.87, 0.0), (-0.09, 0.87, 0.0), (0.0, 1.05, 0.0), (0.10, 0.50, 0.0),
    (-0.10, 0.50, 0.0), (0.0, 1.18, 0.0), (0.10, 0.09, 0.0), (-0.10, 0.09, 0.0), (0.0, 1.30, 0.0),
    (0.10, 0.03, 0.10), (-0.10, 0.03, 0.10), (0.0, 1.50, 0.0), (0.07, 1.42, 0.0), (-0.07, 1.42, 0.0),
    (0.0, 1.62, 0.0), (0.18, 1.42, 0.0), (-0.18, 1.42, 0.0), (0.44, 1.42, 0.0), (-0.44, 1.42, 0.0),
    (0.68, 1.42, 0.0), (-0.68, 1.42, 0.0), (0.76, 1.42, 0.0), (-0.76, 1.42, 0.0)])

# (a, b, radius, z scale): distance measured with z multiplied by the scale, so the torso is flatter front-to-back
_CAPSULES = [((0, 0.92, 0), (0, 1.36, 0), 0.14, 1.5), ((-0.07, 0.88, 0), (0.07, 0.88, 0), 0.12, 1.3),
             ((0, 1.36, 0), (0, 1.56, 0), 0.055, 1.0), ((0, 1.65, 0.01), (0, 1.66, 0.01), 0.10, 1.0),
             ((-0.17, 1.42, 0), (0.17, 1.42, 0), 0.06, 1.0)]
for s in (1, -1):
    _CAPSULES += [((s * 0.17, 1.42, 0), (s * 0.44, 1.42, 0), 0.05, 1.0),
                  ((s * 0.44, 1.42, 0), (s * 0.68, 1.42, 0), 0.04, 1.0),
                  ((s * 0.68, 1.42, 0), (s * 0.78, 1.42, 0), 0.035, 1.0),
                  ((s * 0.09, 0.86, 0), (s * 0.10, 0.50, 0), 0.075, 1.0),
                  ((s * 0.10, 0.50, 0), (s * 0.10, 0.09, 0), 0.055, 1.0),
                  ((s * 0.10, 0.05, 0.0), (s * 0.10, 0.04, 0.14), 0.04, 1.0)]


def _segment_distance(p, a, b, zscale=1.0):
    a, b = np.asarray(a, float), np.asarray(b, float)
    ab = b - a
    t = np.clip(((p - a) @ ab) / max(ab @ ab, 1e-12), 0.0, 1.0)
    d = p - (a + t[..., None] * ab)
    d[..., 2] *= zscale
    return np.linalg.norm(d, axis=-1)


def _field(p):
    k = 0.03  # smooth-min blend radius
    acc = None
    for a, b, r, zs in _CAPSULES:
        d = _segment_distance(p, a, b, zs) - r
        if acc is None:
            acc = d
        else:
            h = np.clip(0.5 + 0.5 * (d - acc) / k, 0.0, 1.0)
            acc = d * (1 - h) + acc * h - k * h * (1 - h)
    return acc


def standin_body(voxel_m=0.02):
    from skimage.measure import marching_cubes
    lo = np.array([-0.9, -0.05, -0.2])
    hi = np.array([0.9, 1.8, 0.25])
    n = np.ceil((hi - lo) / voxel_m).astype(int) + 1
    axes = [lo[i] + voxel_m * np.arange(n[i]) for i in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
    vol = _field(grid.reshape(-1, 3)).reshape(grid.shape[:3])
    verts, faces, _, _ = marching_cubes(vol, 0.0, spacing=(voxel_m,) * 3, allow_degenerate=False)
    verts = verts + lo
    # marching cubes orients faces towards increasing field (outside) in its own index order; make them outward
    fn = face_normals(verts, faces)
    center_out = verts[faces].mean(1) - np.array([0, 1.0, 0])
    if np.sum(np.einsum("ij,ij->i", fn, center_out)) < 0:
        faces = faces[:, ::-1]
    J = _JOINTS
    n_j = len(J)
    child = {p: k for k, p in reversed(list(enumerate(SMPL_PARENTS))) if p >= 0}
    dist = np.empty((len(verts), n_j))
    for k in range(n_j):
        end = J[child[k]] if k in child else J[k] + 1e-3
        if k == 0:
            end = J[3]
        dist[:, k] = _segment_distance(verts, J[k], end)
    w = 1.0 / np.maximum(dist, 1e-3) ** 6
    keep = np.argsort(-w, axis=1)[:, :3]
    mask = np.zeros_like(w, bool)
    np.put_along_axis(mask, keep, True, axis=1)
    w = np.where(mask, w, 0.0)
    w /= w.sum(1, keepdims=True)
    # joint regressor: mean of the vertices nearest to each joint (about the limb's cross-section there)
    reg = np.zeros((n_j, len(verts)))
    for k in range(n_j):
        d = np.linalg.norm(verts - J[k], axis=1)
        near = np.argsort(d)[:24]
        reg[k, near] = 1.0 / len(near)
    bone_d = np.min(dist, axis=1)
    bone_k = np.argmin(dist, axis=1)
    shapedirs = np.zeros((len(verts), 3, 10))
    # girth: outward from the nearest bone (away from the bone point) – approximated by the vertex normal direction
    nrm = normals_scatter(verts, faces)
    shapedirs[:, :, 0] = 0.015 * nrm * np.clip(bone_d / 0.1, 0.3, 1.0)[:, None]
    shapedirs[:, 1, 1] = 0.03 * verts[:, 1]
    del bone_k
    return BodyModel(v_template=verts, faces=faces.astype(np.int64), shapedirs=shapedirs, J_regressor=reg,
                     weights=w, parents=np.array(SMPL_PARENTS), joint_names=SMPL_JOINT_NAMES,
                     source="pleat.garment.standin (capsule stand-in)")
