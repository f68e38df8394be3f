"""Vertex normals: normalize(Σ_{faces f ∋ i} cross(x_b − x_a, x_c − x_a)), gathered through the CSR adjacency
(NADO/NADF) in its order, like the C job. A vertex whose sum has zero length gets (0, 0, 0)."""
import numpy as np


def normals(positions, faces, adjacency_offsets, adjacency_faces):
    x = np.asarray(positions, np.float64)
    f = np.asarray(faces, np.int64)
    face_normals = np.cross(x[f[:, 1]] - x[f[:, 0]], x[f[:, 2]] - x[f[:, 0]])
    offsets = np.asarray(adjacency_offsets, np.int64)
    gathered = face_normals[np.asarray(adjacency_faces, np.int64)]
    summed = np.zeros_like(x)
    counts = np.diff(offsets)
    has = counts > 0
    if gathered.shape[0]:
        summed[has] = np.add.reduceat(gathered, offsets[:-1][has], axis=0)
    length = np.linalg.norm(summed, axis=1, keepdims=True)
    return np.where(length > 0, summed / np.where(length > 0, length, 1.0), 0.0)
