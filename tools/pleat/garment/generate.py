"""Procedural garments cut from the template body's surface, remeshed, offset outward, with diffused skin and shape.

Recipe (docs/garments.md): take the rest (β = 0) body surface, cut it along smooth level sets placed from the joints
(hem and waist planes, a tilted neckline plane, balls around the arm/leg axes for sleeve and trouser ends, balls at the
shoulders for a tank top's armholes), keep the connected piece around the torso/pelvis, add a flared skirt for the
dress, remesh it isotropically to the requested vertex count (Botsch-Kobbelt, gpytoolbox; openings are kept as
feature lines so they stay smooth and get split like any edge), then push it a few millimetres outward along the
normals and out of the body. Skin weights and shape blend shapes are diffused from the body (HOOD): each garment
vertex takes the values of its nearest body vertex, then they are smoothed over the garment graph.
"""
import numpy as np
from scipy.spatial import cKDTree

from . import mesh as M
from .garment import Garment

GARMENT_NAMES = ("tshirt", "tank_top", "long_sleeve", "pants", "dress")
DEFAULT_VERTICES = {"tshirt": 4424, "tank_top": 3000, "long_sleeve": 4400, "pants": 4000, "dress": 4400}
# Offsets out of the body surface, m: the garment's ease
OFFSET_M = {"tshirt": 0.010, "tank_top": 0.007, "long_sleeve": 0.009, "pants": 0.009, "dress": 0.010}
MIN_CLEARANCE_M = 0.004      # every vertex at least this far outside the body (same as the simulator's ε)


class _Joints:
    def __init__(self, body):
        self.J = body.joints()
        self.names = list(body.joint_names)

    def __getitem__(self, name):
        return self.J[self.names.index(name)]


def _ball_cut(center, radius):
    return lambda v: np.linalg.norm(v - center, axis=1) - radius


def _plane_keep(point, normal):
    n = np.asarray(normal, float)
    return lambda v: (v - point) @ (n / np.linalg.norm(n))


def _limb_end_cut(j, a, b, s_end, radius=0.07):
    """Level set removing the limb beyond the fraction s_end of the bone a→b: a ball astride the axis there."""
    axis = j[b] - j[a]
    length = np.linalg.norm(axis)
    center = j[a] + axis / length * (s_end * length + 0.75 * radius)
    return _ball_cut(center, radius)


def _levels(name, j):
    """(list of level functions v → values, keep ≥ 0, seed joint) for one garment on body vertices v."""
    y = np.array([0.0, 1.0, 0.0])
    hip_y = 0.5 * (j["left_hip"][1] + j["right_hip"][1])
    cuts = []
    if name in ("tshirt", "long_sleeve", "tank_top", "dress"):
        # neckline: a ball around the neck, set forward so the opening dips lower in front; the head above it is
        # cut off with it and dropped as a separate piece
        deep = name in ("tank_top", "dress")
        neck_center = j["neck"] + np.array([0.0, 0.04, 0.045 if deep else 0.025])
        cuts.append(_ball_cut(neck_center, 0.115 if deep else 0.095))
        if name == "dress":
            cuts.append(_plane_keep(np.array([0.0, hip_y + 0.02, 0.0]), y))
        else:
            hem = hip_y - (0.06 if name != "tank_top" else 0.04)
            cuts.append(_plane_keep(np.array([0.0, hem, 0.0]), y))
        for side in ("left", "right"):
            sh, el, wr = f"{side}_shoulder", f"{side}_elbow", f"{side}_wrist"
            if name == "tshirt":
                cuts.append(_limb_end_cut(j, sh, el, 0.45))
            elif name == "long_sleeve":
                cuts.append(_limb_end_cut(j, el, wr, 0.85, radius=0.06))
            else:   # tank top and dress: armholes around the shoulder joint
                out = (j[sh] - j["spine3"]) * np.array([1.0, 0.0, 0.0])
                center = j[sh] + 0.15 * out - np.array([0.0, 0.03, 0.0])
                cuts.append(_ball_cut(center, 0.105))
        return cuts, "spine2"
    if name == "pants":
        waist = j["spine1"] - np.array([0.0, 0.03, 0.0])
        cuts.append(_plane_keep(waist, -y))
        for side in ("left", "right"):
            cuts.append(_limb_end_cut(j, f"{side}_knee", f"{side}_ankle", 0.82, radius=0.07))
        return cuts, "pelvis"
    raise ValueError(f"unknown garment {name!r}; known: {', '.join(GARMENT_NAMES)}")


def _skirt(v, f, j, hem_y, flare=0.45, step=0.02):
    """Extend the lowest boundary loop down to hem_y as a flared skirt (same orientation as the bodice)."""
    loops = M.boundary_loops(f)
    low = min(loops, key=lambda L: v[L, 1].mean())
    top_y = v[low, 1].mean()
    center = np.array([j["pelvis"][0], 0.0, j["pelvis"][2]])
    rel = (v[low] - center) * np.array([1.0, 0.0, 1.0])
    r0 = np.linalg.norm(rel, axis=1)
    dirs = rel / r0[:, None]
    n_levels = max(2, int(np.ceil((top_y - hem_y) / step)))
    verts = [v]
    ring_prev = low
    faces = [f]
    nxt_index = len(v)
    for k in range(1, n_levels + 1):
        s = k / n_levels
        depth = s * (top_y - hem_y)
        r = (1 - s) * r0 + s * r0.mean() + flare * depth
        ring = center + dirs * r[:, None] + np.array([0.0, top_y - depth, 0.0])
        ring[:, 1] = v[low, 1] - depth
        idx = np.arange(nxt_index, nxt_index + len(low))
        nxt_index += len(low)
        verts.append(ring)
        a, b = ring_prev, np.roll(ring_prev, -1)          # boundary half-edges a→b of the piece above
        a2, b2 = idx, np.roll(idx, -1)
        faces.append(np.stack([b, a, a2], 1))
        faces.append(np.stack([b, a2, b2], 1))
        ring_prev = idx
    return np.concatenate(verts), np.concatenate(faces), top_y


def _botsch(v, f, h, iterations):
    import gpytoolbox as gp
    be = M.boundary_edges(f)
    u, g = gp.remesh_botsch(v, f.astype(np.int32), iterations, h, True, feature_edges=be.astype(np.int32))
    return M.compact(u, np.asarray(g, np.int64))


def _remesh(v, f, n_target, iterations=10):
    area = 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1).sum()
    h = np.sqrt(2.0 * area / (np.sqrt(3.0) * n_target))
    best = None
    for _ in range(4):
        u, g = _botsch(v, f, h, iterations)
        u, g = M.coarsen_boundary(u, g, h)       # Botsch-Kobbelt never removes boundary vertices: do it here
        u, g = _botsch(u, g, h, iterations // 2)
        if best is None or abs(len(u) - n_target) < abs(len(best[0]) - n_target):
            best = (u, g)
        ratio = len(u) / n_target
        if abs(ratio - 1.0) < 0.02:
            break
        h *= np.sqrt(ratio)
    return best


def diffuse_from_body(x, faces, body, query_points=None, smooth_iterations=10, shape_smooth_iterations=3,
                      k_influences=4, beta_check=3.0):
    """(skin_indices [N,K], skin_weights [N,K], shape_blend [B,N,3]) from the nearest body vertices, smoothed over
    the garment graph. Shape blend shapes are smoothed less (they must keep up with local changes such as the
    crotch and armpits) and, where the smoothed one would put a vertex inside the body at β_b = ±beta_check, the
    vertex takes its nearest body vertex's unsmoothed shape direction instead."""
    tree = cKDTree(body.v_template)
    _, nearest = tree.query(x if query_points is None else query_points)
    w = body.weights[nearest].copy()                               # [N, J]
    raw = np.moveaxis(body.shapedirs[nearest], 2, 0).copy()        # [B, N, 3]
    sd = raw.copy()
    A = M.adjacency(faces, len(x))
    deg = np.asarray(A.sum(1)).ravel()
    P = (A.multiply(1.0 / np.maximum(deg, 1)[:, None])).tocsr()   # row-stochastic neighbour average
    for _ in range(smooth_iterations):
        w = 0.5 * w + 0.5 * (P @ w)
    for _ in range(shape_smooth_iterations):
        sd = 0.5 * sd + 0.5 * np.stack([P @ s for s in sd])
    if beta_check:
        from ..body.model import BodyCollider
        for b in range(sd.shape[0]):
            if not np.any(body.shapedirs[:, :, b]):
                continue
            for sign in (-1.0, 1.0):
                beta = np.zeros(sd.shape[0])
                beta[b] = sign * beta_check
                collider = BodyCollider(body.shaped_vertices(beta), body.faces)
                dist, _, _ = collider.signed_distance(x + beta[b] * sd[b], k=8)
                bad = dist < 0.5 * MIN_CLEARANCE_M
                sd[b, bad] = raw[b, bad]
    order = np.argsort(-w, axis=1)[:, :k_influences]
    top = np.take_along_axis(w, order, axis=1)
    top = np.maximum(top, 0.0)
    top /= top.sum(1, keepdims=True)
    return order.astype(np.int32), top.astype(np.float32), sd.astype(np.float32)


def pinned_vertices(name, x, faces):
    """Waistband (top opening) of pants; none for tops and the dress (they hang on the shoulders)."""
    if name != "pants":
        return np.zeros(0, np.int32)
    loops = M.boundary_loops(faces)
    waist = max(loops, key=lambda L: x[L, 1].mean())
    return np.sort(waist).astype(np.int32)


def make_garment(name, vertices=None, body=None, offset_m=None):
    """Generate garment `name` (one of GARMENT_NAMES) with about `vertices` vertices on `body` (default: the
    shipped body, assets/body.npz)."""
    from ..body.model import BodyCollider
    if body is None:
        from ..body import BodyModel
        body = BodyModel.load()
    if name not in GARMENT_NAMES:
        raise ValueError(f"unknown garment {name!r}; known: {', '.join(GARMENT_NAMES)}")
    n_target = int(vertices or DEFAULT_VERTICES[name])
    j = _Joints(body)
    v, f = body.v_template, body.faces
    cuts, seed = _levels(name, j)
    for level in cuts:
        v, f = M.cut_mesh(v, f, level(v))
    v, f = M.keep_component(v, f, j[seed])
    skirt_top = None
    if name == "dress":
        knee_y = 0.5 * (j["left_knee"][1] + j["right_knee"][1])
        v, f, skirt_top = _skirt(v, f, j, knee_y - 0.03)
    v, f = _remesh(v, f, n_target)
    offset = OFFSET_M[name] if offset_m is None else offset_m
    x = v + offset * M.vertex_normals(v, f)
    collider = BodyCollider(body.v_template, body.faces)
    x = collider.push_out(x, MIN_CLEARANCE_M + offset * 0.5, iterations=6)
    query = None
    if skirt_top is not None:
        # skirt vertices follow the hips, not the nearest leg: look them up straight above, on the hip ring
        query = x.copy()
        below = x[:, 1] < skirt_top
        query[below, 1] = skirt_top
        c = np.array([j["pelvis"][0], j["pelvis"][2]])
        rel = query[below][:, [0, 2]] - c
        query[below, 0] = c[0] + rel[:, 0] * 0.6
        query[below, 2] = c[1] + rel[:, 1] * 0.6
    skin_indices, skin_weights, shape_blend = diffuse_from_body(x, f, body, query_points=query)
    return Garment.build(name=name, template=x, faces=f, skin_indices=skin_indices, skin_weights=skin_weights,
                         shape_blend=shape_blend, pinned=pinned_vertices(name, x, f),
                         collision_exclude=collision_exclude(name))


# A skirt hangs where the hands swing: it collides with the trunk and legs only (BodyCollider's `collide`).
SKIRT_EXCLUDED_JOINTS = ("left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_hand", "right_hand")


def collision_exclude(name):
    """Body joints (indices) whose vertices garment `name` does not collide with: the forearms and hands for the
    dress, none for the others (their cloth is never where a hand swings through it)."""
    from ..body.model import SMPL_JOINT_NAMES
    if name != "dress":
        return np.zeros(0, np.int32)
    return np.array([SMPL_JOINT_NAMES.index(j) for j in SKIRT_EXCLUDED_JOINTS], np.int32)


def garment_from_obj(path, body=None, name=None, pinned=None):
    """A user's garment mesh (rest pose, fitted to the template body) through the same diffusion."""
    from pathlib import Path
    if body is None:
        from ..body import BodyModel
        body = BodyModel.load()
    v, f = M.read_obj(path)
    v, f = M.compact(v, f)
    problems = M.check_manifold(f, len(v))
    if problems:
        raise ValueError(f"{path}: not an oriented manifold mesh: {'; '.join(problems)}")
    skin_indices, skin_weights, shape_blend = diffuse_from_body(v, f, body)
    return Garment.build(name=name or Path(path).stem, template=v, faces=f, skin_indices=skin_indices,
                         skin_weights=skin_weights, shape_blend=shape_blend,
                         pinned=np.zeros(0, np.int32) if pinned is None else pinned)
