"""A flat rectangular sheet: the simplest garment, used by the simulator tests and the cross-check scene."""
import numpy as np


def grid_sheet(nx, nz, width_m, depth_m, height_m=0.0, center=(0.0, 0.0)):
    """Vertices [nx·nz, 3] in the plane y = height_m, faces [2(nx−1)(nz−1), 3] with normals along +Y."""
    xs = np.linspace(-0.5, 0.5, nx) * width_m + center[0]
    zs = np.linspace(-0.5, 0.5, nz) * depth_m + center[1]
    X, Z = np.meshgrid(xs, zs, indexing="ij")
    v = np.stack([X.ravel(), np.full(X.size, height_m), Z.ravel()], axis=1)
    i, j = np.meshgrid(np.arange(nx - 1), np.arange(nz - 1), indexing="ij")
    a = (i * nz + j).ravel()
    b = a + nz
    c = b + 1
    d = a + 1
    # alternate the diagonal so the sheet has no preferred shear direction
    flip = ((i + j) % 2 == 1).ravel()
    f1 = np.where(flip[:, None], np.stack([a, d, b], 1), np.stack([a, d, c], 1))
    f2 = np.where(flip[:, None], np.stack([b, d, c], 1), np.stack([a, c, b], 1))
    return v, np.concatenate([f1, f2]).astype(np.int64)
