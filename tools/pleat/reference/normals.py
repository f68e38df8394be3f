"""Vertex normals n_i = normalize(Σ_{faces f ∋ i} cross(x_b − x_a, x_c − x_a)), area weighted (sdk/src/normals.c).

Two algorithms, each with one name in C, GLSL and here, with the same argument names:
    face_normals + normals_gather   plFaceNormalsJob + plNormalsGatherJob, shaders/face_normals.comp +
                                    shaders/normals_gather.comp: each face's cross product once, then per vertex the
                                    sum over the CSR adjacency (NADO/NADF) in its order. `normals` is the two in a row.
    normals_scatter                 plNormalsScatterJob (the CPU path on one thread): each face added to its three
                                    vertices in ascending face order — the same sums on a valid asset.
A vertex whose sum has zero length gets (0, 0, 0)."""
import numpy as np


def _normalize(sums):
    length = np.linalg.norm(sums, axis=-1, keepdims=True)
    return np.where(length > 0, sums / np.where(length > 0, length, 1.0), 0.0)


def face_normals(positions, faces):
    """positions [..., N, 3]; faces [F, 3] → unnormalised cross(x_b − x_a, x_c − x_a) [..., F, 3]."""
    x = np.asarray(positions, np.float64)
    f = np.asarray(faces, np.int64)
    a = x[..., f[:, 0], :]
    return np.cross(x[..., f[:, 1], :] - a, x[..., f[:, 2], :] - a)


def normals_gather(face_normals, adjacency_offsets, adjacency_faces):
    """face_normals [..., F, 3]; adjacency_offsets [N + 1], adjacency_faces [3F] (CSR) → unit normals [..., N, 3]."""
    offsets = np.asarray(adjacency_offsets, np.int64)
    gathered = np.asarray(face_normals, np.float64)[..., np.asarray(adjacency_faces, np.int64), :]
    sums = np.zeros(gathered.shape[:-2] + (len(offsets) - 1, 3))
    has = np.diff(offsets) > 0
    if gathered.shape[-2]:
        sums[..., has, :] = np.add.reduceat(gathered, offsets[:-1][has], axis=-2)
    return _normalize(sums)


def normals_scatter(positions, faces):
    """positions [..., N, 3]; faces [F, 3] → unit normals [..., N, 3]: each face added to its vertices in ascending
    face order (bincount sums in input order), as plNormalsScatter_Scalar. The vertex normals of every tool (body,
    garment, simulator collider) are these."""
    x = np.asarray(positions, np.float64)
    corners = np.asarray(faces, np.int64).reshape(-1)              # face 0's corners, then face 1's, ...
    per_corner = np.repeat(face_normals(x, faces).reshape(-1, np.shape(faces)[0], 3), 3, axis=1)
    n = x.shape[-2]
    sums = np.stack([np.stack([np.bincount(corners, weights=fn[:, k], minlength=n) for k in range(3)], axis=-1)
                     for fn in per_corner])
    return _normalize(sums.reshape(x.shape))


def normals(positions, faces, adjacency_offsets, adjacency_faces):
    """face_normals, then normals_gather: the normals of plInstance_Step and of the GL path. positions [..., N, 3]."""
    return normals_gather(face_normals(positions, faces), adjacency_offsets, adjacency_faces)
