"""Meshes drawn to a PNG with matplotlib: flat-shaded triangles sorted back to front (painter's algorithm), seen
orthographically from the front (+Z) or any yaw, one panel per column of a contact sheet.

pleat-show, pleat-preview and the retargeting report (pleat.motion.check) draw through this; it imports only
pleat.fileio, so the motion check can draw without reaching pleat.show, which loads clips.
"""
import numpy as np

from pleat.fileio import save_figure

BODY_COLOR = (0.80, 0.70, 0.62)
GARMENT_COLORS = [(0.25, 0.45, 0.75), (0.75, 0.30, 0.30), (0.30, 0.62, 0.40), (0.62, 0.45, 0.75),
                  (0.85, 0.62, 0.25)]
LIGHT = np.array([0.4, 0.6, 0.7])


def project(points, yaw_deg=0.0, elevation_deg=8.0):
    """Orthographic camera looking at −Z after rotating the scene by yaw about +Y: → (u, v, depth)."""
    a = np.radians(yaw_deg)
    e = np.radians(elevation_deg)
    ry = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
    rx = np.array([[1, 0, 0], [0, np.cos(e), -np.sin(e)], [0, np.sin(e), np.cos(e)]])
    p = points @ (rx @ ry).T
    return p[..., 0], p[..., 1], p[..., 2]


def draw_meshes(ax, meshes, yaw_deg=0.0, elevation_deg=8.0):
    """meshes: list of (vertices [V,3], faces [F,3], rgb). Draws them together, depth-sorted, onto `ax`."""
    from matplotlib.collections import PolyCollection
    polys, colors, depths = [], [], []
    light = LIGHT / np.linalg.norm(LIGHT)
    for v, f, rgb in meshes:
        u, w, z = project(np.asarray(v, np.float64), yaw_deg, elevation_deg)
        p = np.stack([u, w, z], axis=1)
        tri = p[f]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-20)
        # two-sided: back faces (the inside of a garment) are lit as if flipped, a little darker
        facing = n[:, 2]
        shade = 0.35 + 0.65 * np.abs(n @ light)
        shade = np.where(facing >= 0, shade, 0.75 * shade)
        polys.append(tri[:, :, :2])
        colors.append(np.clip(np.asarray(rgb)[None, :] * shade[:, None], 0, 1))
        depths.append(tri[:, :, 2].mean(1))
    polys = np.concatenate(polys)
    colors = np.concatenate(colors)
    order = np.argsort(np.concatenate(depths))            # far (small z) first
    ax.add_collection(PolyCollection(polys[order], facecolors=colors[order], edgecolors="none", antialiased=False))
    allp = polys.reshape(-1, 2)
    lo, hi = allp.min(0), allp.max(0)
    pad = 0.03 * (hi - lo).max()
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")
    ax.axis("off")


def contact_sheet(panels, out, titles=None, panel_px=260, dpi=100):
    """panels: list of list-of-meshes (one per column), each drawn with `draw_meshes`."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    n = len(panels)
    fig, axes = plt.subplots(1, n, figsize=(n * panel_px / dpi, 1.6 * panel_px / dpi), dpi=dpi, squeeze=False)
    for k, (ax, meshes) in enumerate(zip(axes[0], panels)):
        yaw = 0.0
        if isinstance(meshes, tuple):
            meshes, yaw = meshes
        draw_meshes(ax, meshes, yaw_deg=yaw)
        if titles:
            ax.set_title(titles[k], fontsize=9)
    fig.subplots_adjust(left=0.01, right=0.99, top=0.93, bottom=0.01, wspace=0.02)
    save_figure(fig, out, dpi=dpi)
    plt.close(fig)
