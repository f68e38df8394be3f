"""Forearms and hands inside the body: the self-intersection half of the retargeting check (pleat.motion.check has
the limits and docs/motion.md the manual).

A probe (one of PROBES_PER_ARM forearm and hand vertices per arm of the posed mean body, spread evenly over them) is
inside when

1. its **generalized winding number** with respect to the posed body *without its arms* is above 1/2. The arms' faces
   (every face touching a vertex whose largest skin weight is a shoulder, elbow, wrist or hand) are taken out, so a
   probe is never tested against its own arm, and each hole this leaves at a shoulder is closed by a fan of triangles
   to the mean of its rim. The rest of the shipped body is closed, so the winding number is 1 inside and 0 outside,
   with no normals or nearest points whose sign could flip in a crease (armpit, crotch); and
2. it is more than `depth_m` from that surface (its nearest body vertex or point on a cap), so that a hand resting
   on a hip or a thigh, which linear blend skinning sinks in by a centimetre or so, or grazing the body, does not
   count.

Cost. The winding number is a sum of triangle solid angles (Van Oosterom and Strackee's formula). To keep it within
what a clip load can afford, the surface is coarsened once per body (the vertices of each CELL_M cube of one body part
merged into one of them: a vertex map keeps a closed surface closed, and moves it by millimetres, far less than the
depth margin) and its faces grouped into patches and the patches into regions of neighbours. A region farther from
the probe than FAR_RATIO times its radius adds its dipole term, (Σ area vectors)·(centre − probe) / (4π r³); of a
near region, each far patch adds its dipole; only near patches are summed triangle by triangle. Against the exact
sum over every triangle of the coarse surface (probes and random points around a posed body), the error is below
0.05, far from the 1/2 threshold. The depth is measured to the whole (not coarsened) surface, posed only in the
frames that have a probe with a winding number above 1/2.
"""
import numpy as np

ARM_JOINTS = tuple(f"{s}_{j}" for s in ("left", "right") for j in ("shoulder", "elbow", "wrist", "hand"))
PROBE_JOINTS = tuple(f"{s}_{j}" for s in ("left", "right") for j in ("elbow", "wrist", "hand"))
PROBES_PER_ARM = 64
CELL_M = 0.02
PATCH_FACES = 64
PATCH_SIZE_M = 0.08
REGION_PATCHES = 16
REGION_SIZE_M = 0.3
FAR_RATIO = 2.0
FRAME_CHUNK = 8                         # frames per pass: their arrays stay in cache
CAP_RINGS = (0.0, 0.25, 0.5, 0.75)      # depth points on a cap: its centre and rings towards its rim


class ArmlessSurface:
    """The closed, coarsened body-without-arms of one body (built once per body; see the module doc).

    vertices [N] i64: the body vertices that are its corners; faces [F, 3]: into [vertices; cap centres], patch by
    patch; patch_start [P + 1]: where each patch's faces begin in `faces`; region_start [R + 1]: where each region's
    patches begin; corners [P, C]: each patch's corners
    (padded by repeating one); cap_rims: per cap, its rim (positions in `vertices`); fine [N'] i64: every body
    vertex of the surface before coarsening (for the depth); probes [Q] i64: the probed body vertices."""

    def __init__(self, body, probes_per_arm=PROBES_PER_ARM):
        from scipy.sparse import csr_matrix
        self.skin_weights = csr_matrix(body.weights)        # a few joints per vertex
        names = list(body.joint_names)
        dominant = np.argmax(body.weights, axis=1)
        arm = np.isin(dominant, [names.index(n) for n in ARM_JOINTS])
        keep = body.faces[~arm[body.faces].any(axis=1)]
        self.fine = np.unique(keep)
        keep = self._coarsen(body.v_template, keep, self.fine, dominant)
        self.vertices = np.unique(keep)
        renumber = np.full(body.num_vertices, -1, np.int64)
        renumber[self.vertices] = np.arange(len(self.vertices))
        faces = renumber[keep]
        self.cap_rims, caps = self._caps(faces, len(self.vertices))
        faces = np.concatenate([faces, caps])
        rest = self.points(body.v_template[None, self.vertices])[0]
        part = np.concatenate([dominant[self.vertices[faces[: len(faces) - len(caps), 0]]],
                               np.full(len(caps), -1)])       # the caps: a part of their own
        centres = rest[faces].mean(axis=1)
        groups = _split(centres, part, PATCH_FACES, PATCH_SIZE_M)
        # patches into regions of neighbouring patches, each region's patches in one run, each patch's faces in one
        regions = _split(np.array([centres[g].mean(axis=0) for g in groups]), np.array([part[g[0]] for g in groups]),
                         REGION_PATCHES, REGION_SIZE_M)
        groups = [groups[i] for r in regions for i in r]
        self.region_start = np.cumsum([0] + [len(r) for r in regions])
        self.faces = faces[np.concatenate(groups)]
        self.patch_start = np.cumsum([0] + [len(g) for g in groups])
        corners = [np.unique(faces[g]) for g in groups]
        self.corners = np.array([np.resize(c, max(map(len, corners))) for c in corners])
        self.probes = np.concatenate([_spread(body.v_template, np.flatnonzero(
            np.isin(dominant, [names.index(n) for n in PROBE_JOINTS if n.startswith(side)])), probes_per_arm)
            for side in ("left", "right")])

    @staticmethod
    def _coarsen(x, faces, used, part):
        """Faces after merging the vertices of each CELL_M cube (within one body part, so that no face joins two
        parts that move apart) into the one nearest their mean. A vertex map takes a closed surface to a closed one
        (the faces it collapses drop out, the others keep their orientation), so the winding number stays 1 inside and
        0 outside; the surface moves by a few millimetres."""
        cell = np.floor(x[used] / CELL_M).astype(np.int64)
        _, cluster = np.unique(np.column_stack([cell, part[used]]), axis=0, return_inverse=True)
        cluster = cluster.ravel()
        mean = np.zeros((cluster.max() + 1, 3))
        np.add.at(mean, cluster, x[used])
        mean /= np.bincount(cluster)[:, None]
        order = np.lexsort((np.linalg.norm(x[used] - mean[cluster], axis=1), cluster))
        first = order[np.r_[True, cluster[order][1:] != cluster[order][:-1]]]
        to = np.arange(len(x))
        to[used] = used[first][cluster]
        out = to[faces]
        return out[(out[:, 0] != out[:, 1]) & (out[:, 1] != out[:, 2]) & (out[:, 2] != out[:, 0])]

    @staticmethod
    def _caps(faces, n):
        """The holes' rims and the fans that close them. A rim edge is one whose two directions do not cancel over
        the faces (after coarsening an edge may have more than two faces); the cap runs it backwards, so that the
        closed surface keeps one orientation."""
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components
        edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
        net = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n)).tocsr()
        net = (net - net.T).tocoo()
        pos = net.data > 0
        rim = np.repeat(np.column_stack([net.row[pos], net.col[pos]]), net.data[pos].astype(np.int64), axis=0)
        if not len(rim):
            return [], np.zeros((0, 3), np.int64)
        graph = coo_matrix((np.ones(len(rim)), (rim[:, 0], rim[:, 1])), shape=(n, n))
        _, label = connected_components(graph, directed=False)
        loops = np.unique(label[rim[:, 0]])
        rims = [np.unique(rim[label[rim[:, 0]] == c]) for c in loops]
        centre = n + np.searchsorted(loops, label[rim[:, 0]])
        return rims, np.stack([rim[:, 1], rim[:, 0], centre], axis=1)

    def points(self, x):
        """Surface vertex positions [T, N, 3] → the same with the cap centres appended [T, N + caps, 3]."""
        centres = [x[:, r].mean(axis=1, keepdims=True) for r in self.cap_rims]
        return np.concatenate([x] + centres, axis=1)

    def cap_points(self, x):
        """Points spread over the caps of surface vertices x [T, N, 3]: their centres and rings towards the rims."""
        out = []
        for r in self.cap_rims:
            c = x[:, r].mean(axis=1, keepdims=True)
            out += [c + s * (x[:, r] - c) for s in CAP_RINGS]
        return np.concatenate(out, axis=1) if out else x[:, :0]


def _split(centres, part, most, size_m):
    """Items (faces, or patches) in groups of at most `most` neighbours within one body part (`part`: the joint that
    moves them, so that a group stays as small when the body bends) and `size_m` across, by median splits along the
    widest axis of their rest-pose centres → a list of index arrays."""
    groups, todo = [], [np.flatnonzero(part == k) for k in np.unique(part)]
    while todo:
        g = todo.pop()
        c = centres[g]
        extent = c.max(axis=0) - c.min(axis=0)
        if len(g) <= most and extent.max() <= size_m:
            groups.append(g)
            continue
        order = g[np.argsort(c[:, int(np.argmax(extent))], kind="stable")]
        todo += [order[: len(g) // 2], order[len(g) // 2:]]
    return groups


def _spread(x, idx, count):
    """`count` of the vertices idx spread evenly over their rest-pose surface (farthest-point sampling): the hand
    has six times the forearm's vertices, packed into the fingers, and a plain stride would weigh them so."""
    pts = x[idx]
    pick = [int(np.argmin(pts[:, 1]))]
    d = np.linalg.norm(pts - pts[pick[0]], axis=1)
    for _ in range(min(count, len(idx)) - 1):
        pick.append(int(np.argmax(d)))
        d = np.minimum(d, np.linalg.norm(pts - pts[pick[-1]], axis=1))
    return idx[np.sort(pick)]


def solid_angle_sum(tri, p):
    """Σ over triangles of the solid angle / 4π: tri [..., K, 3, 3] seen from p [..., 3] → [...]."""
    a, b, c = (tri[..., i, :] - p[..., None, :] for i in range(3))
    la, lb, lc = (np.linalg.norm(v, axis=-1) for v in (a, b, c))
    det = np.einsum("...i,...i->...", a, np.cross(b, c))
    den = (la * lb * lc + np.einsum("...i,...i->...", a, b) * lc + np.einsum("...i,...i->...", b, c) * la
           + np.einsum("...i,...i->...", c, a) * lb)
    return np.arctan2(det, den).sum(axis=-1) / (2.0 * np.pi)


def _dots(a, b):
    """a [T, Q, 3] · b [T, P, 3] → [T, Q, P], written out: a product this small gains nothing from BLAS but its
    threads' start-up, which on a busy machine costs more than the product."""
    return sum(a[..., i, None] * b[:, None, :, i] for i in range(3))


def _runs(start, idx):
    """For items idx of runs that begin at start[idx] (start [R + 1]): (position in idx, member) of every member."""
    count = start[idx + 1] - start[idx]
    owner = np.repeat(np.arange(len(idx)), count)
    return owner, np.arange(count.sum()) + np.repeat(start[idx] - np.cumsum(count) + count, count)


def winding_numbers(surface, x, p):
    """Winding numbers [T, Q] of points p [T, Q, 3] w.r.t. the surface whose points (`surface.points`) are x [T, N, 3].

    Three levels: a region (a few hundred faces) far from the probe adds its dipole; of a near region, each patch
    that is far adds its dipole; of a near patch, each triangle its solid angle."""
    T, Q = p.shape[:2]
    tri = x[:, surface.faces]                                           # [T, F, 3, 3]
    area = 0.5 * np.cross(tri[:, :, 1] - tri[:, :, 0], tri[:, :, 2] - tri[:, :, 0])
    corner = x[:, surface.corners]                                      # [T, P, C, 3]
    centre = corner.mean(axis=2)
    radius = np.sqrt(((corner - centre[:, :, None]) ** 2).sum(-1).max(axis=2))
    normal = np.add.reduceat(area, surface.patch_start[:-1], axis=1)    # [T, P, 3]
    starts = surface.region_start[:-1]
    r_normal = np.add.reduceat(normal, starts, axis=1)                  # [T, R, 3]
    r_centre = np.add.reduceat(centre, starts, axis=1) / np.diff(surface.region_start)[None, :, None]
    member = np.repeat(np.arange(len(starts)), np.diff(surface.region_start))
    r_radius = np.maximum.reduceat(np.linalg.norm(centre - r_centre[:, member], axis=-1) + radius, starts, axis=1)
    # regions: |c − p|² and (c − p)·n from products of [Q, 3] and [3, R], no [T, Q, R, 3] array
    dist2 = np.maximum((p * p).sum(-1)[..., None] - 2.0 * _dots(p, r_centre) + (r_centre * r_centre).sum(-1)[:, None],
                       1e-24)
    w = ((r_centre * r_normal).sum(-1)[:, None] - _dots(p, r_normal)) / (dist2 * np.sqrt(dist2))
    ti, qi, ri = np.nonzero(dist2 <= (FAR_RATIO * r_radius[:, None]) ** 2)
    w[ti, qi, ri] = 0.0
    out = w.sum(axis=2).ravel()
    if len(ti):
        # the patches of the near regions
        k, pi = _runs(surface.region_start, ri)
        ti, qi = ti[k], qi[k]
        d = centre[ti, pi] - p[ti, qi]
        dist2 = np.maximum((d * d).sum(-1), 1e-24)
        near = dist2 <= (FAR_RATIO * radius[ti, pi]) ** 2
        w = np.where(near, 0.0, (d * normal[ti, pi]).sum(-1) / (dist2 * np.sqrt(dist2)))
        out += np.bincount(ti * Q + qi, w, minlength=out.size)
        ti, qi, pi = ti[near], qi[near], pi[near]
    out /= 4.0 * np.pi
    if len(ti):
        # the triangles of the near patches
        k, f = _runs(surface.patch_start, pi)
        t, q = ti[k], qi[k]
        out += np.bincount(t * Q + q, solid_angle_sum(tri[t, f][:, None], p[t, q]), minlength=out.size)
    return out.reshape(T, Q)


def probes_inside(body, surface, M, v, depth_m):
    """For skinning matrices M [T, J, 3, 4] of the shaped body v [V, 3]: bool [T, Q], probes inside (module doc)."""
    J = M.shape[1]

    def posed(idx, frames=slice(None)):
        # skin weights are sparse (a few joints per vertex): a sparse product
        m = M[frames].transpose(1, 0, 2, 3).reshape(J, -1)
        A = (surface.skin_weights[idx] @ m).reshape(len(idx), -1, 3, 4)
        return np.einsum("vtij,vj->tvi", A[..., :3], v[idx]) + A[..., 3].transpose(1, 0, 2)

    xs = posed(surface.vertices)
    ps = posed(surface.probes)
    pts = surface.points(xs)
    # a few frames at a time: the arrays of one chunk stay in cache
    out = np.concatenate([winding_numbers(surface, pts[i:i + FRAME_CHUNK], ps[i:i + FRAME_CHUNK])
                          for i in range(0, len(ps), FRAME_CHUNK)]) > 0.5
    caps = surface.cap_points(xs)
    frames = np.flatnonzero(out.any(axis=1))
    # the depth to the whole surface, not the coarse one: posed only in the frames that need it
    fine = posed(surface.fine, frames) if len(frames) else None
    for i, t in enumerate(frames):
        cand = np.flatnonzero(out[t])
        q, y = ps[t, cand], np.concatenate([fine[i], caps[t]])
        d2 = ((q * q).sum(1)[:, None] - 2.0 * np.einsum("qi,vi->qv", q, y) + (y * y).sum(1)[None]).min(axis=1)
        out[t, cand] = d2 > depth_m ** 2
    return out
