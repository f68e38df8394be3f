"""Triangle-mesh helpers for garment making: level-set cuts, components, boundary loops, checks, OBJ reading."""
import numpy as np

# Area-weighted unit vertex normals: the runtime's, defined once (pleat.reference.normals); M.vertex_normals for callers.
from pleat.reference.normals import normals_scatter as vertex_normals  # noqa: F401


def cut_mesh(vertices, faces, level):
    """Keep the part of the mesh where `level` ≥ 0, splitting the triangles the zero level crosses.

    Returns (vertices, faces); new vertices lie on the crossed edges at the linearly interpolated zero, so the cut
    is a smooth curve rather than a staircase of whole triangles. Face orientation is preserved.
    """
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64)
    lv = np.asarray(level, np.float64).copy()
    # level functions are distances in metres (gradient ≤ 1): pushing values within 2 mm of zero to ±2 mm moves the
    # cut by at most 2 mm and keeps every new vertex ≥ ~2 mm from the old ones (no sliver edges)
    snap = 2e-3
    near = np.abs(lv) < snap
    lv[near] = np.where(lv[near] >= 0, snap, -snap)
    inside = lv > 0
    new_pts = []
    edge_vertex = {}

    def crossing(a, b):
        key = (min(a, b), max(a, b))
        if key not in edge_vertex:
            t = lv[a] / (lv[a] - lv[b])
            edge_vertex[key] = len(v) + len(new_pts)
            new_pts.append(v[a] + t * (v[b] - v[a]))
        return edge_vertex[key]

    out = [f[inside[f].all(1)]]
    extra = []
    for tri in f[(inside[f].sum(1) == 1) | (inside[f].sum(1) == 2)]:
        ins = inside[tri]
        r = int(np.argmax(ins)) if ins.sum() == 1 else int(np.argmin(ins))
        a, b, c = np.roll(tri, -r)                     # a is the odd one out
        if ins.sum() == 1:                             # a inside
            extra.append((a, crossing(a, b), crossing(a, c)))
        else:                                          # a outside, b and c inside
            pab, pca = crossing(a, b), crossing(c, a)
            extra.append((pab, b, c))
            extra.append((pab, c, pca))
    if extra:
        out.append(np.array(extra, np.int64))
    nf = np.concatenate(out)
    nv = np.concatenate([v, np.array(new_pts).reshape(-1, 3)])
    return compact(nv, nf)


def compact(vertices, faces):
    used = np.unique(faces)
    remap = np.full(len(vertices), -1, np.int64)
    remap[used] = np.arange(len(used))
    return np.asarray(vertices)[used], remap[faces]


def face_components(faces, n_vertices):
    """Connected-component label per vertex (through shared vertices)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    f = np.asarray(faces, np.int64)
    r = np.concatenate([f[:, 0], f[:, 1], f[:, 2]])
    c = np.concatenate([f[:, 1], f[:, 2], f[:, 0]])
    g = coo_matrix((np.ones(len(r)), (r, c)), shape=(n_vertices, n_vertices))
    return connected_components(g, directed=False)[1]


def keep_component(vertices, faces, seed_point):
    """The connected component that holds the vertex nearest to `seed_point`."""
    labels = face_components(faces, len(vertices))
    seed = int(np.argmin(np.linalg.norm(vertices - np.asarray(seed_point), axis=1)))
    keep = labels[faces[:, 0]] == labels[seed]
    return compact(vertices, faces[keep])


def boundary_edges(faces):
    """Directed half-edges (a, b) with no twin (b, a): the openings, oriented as the faces run."""
    f = np.asarray(faces, np.int64)
    he = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    key = he[:, 0] * (f.max() + 1) + he[:, 1]
    twin = he[:, 1] * (f.max() + 1) + he[:, 0]
    return he[~np.isin(twin, key)]


def boundary_loops(faces):
    """Ordered vertex loops of the boundary, each following the half-edge direction."""
    nxt = {int(a): int(b) for a, b in boundary_edges(faces)}
    loops = []
    while nxt:
        start = next(iter(nxt))
        loop = [start]
        cur = nxt.pop(start)
        while cur != start:
            loop.append(cur)
            cur = nxt.pop(cur)
        loops.append(np.array(loop, np.int64))
    return loops


def coarsen_boundary(vertices, faces, spacing, ratio=0.6):
    """Collapse boundary edges shorter than ratio·spacing (the shorter first, into the midpoint), so openings get
    the interior's resolution. A collapse that would break manifoldness is skipped."""
    v = np.asarray(vertices, np.float64).copy()
    f = np.asarray(faces, np.int64)
    failed = set()
    while True:
        be = boundary_edges(f)
        length = np.linalg.norm(v[be[:, 0]] - v[be[:, 1]], axis=1)
        order = [i for i in np.argsort(length) if length[i] < ratio * spacing
                 and (int(be[i, 0]), int(be[i, 1])) not in failed]
        if not order:
            break
        # a batch of collapses far enough apart not to interact (no shared face), checked together
        face_of = {}
        for fi, tri in enumerate(f):
            for x in tri:
                face_of.setdefault(int(x), []).append(fi)
        used_faces, batch = set(), []
        for i in order:
            a, b = int(be[i, 0]), int(be[i, 1])
            touched = set(face_of[a]) | set(face_of[b])
            ring = {int(x) for fi in touched for x in f[fi]}
            ring_faces = {fi for x in ring for fi in face_of[x]}
            if ring_faces & used_faces:
                continue
            used_faces |= ring_faces
            batch.append((a, b))
        for attempt in (batch, batch[:1]):
            nf = f.copy()
            for a, b in attempt:
                nf[nf == b] = a
            nf = nf[(nf[:, 0] != nf[:, 1]) & (nf[:, 1] != nf[:, 2]) & (nf[:, 0] != nf[:, 2])]
            if not check_manifold(nf, len(v), allow_unreferenced=True):
                for a, b in attempt:
                    v[a] = 0.5 * (v[a] + v[b])
                f = nf
                break
            if len(attempt) == 1:
                failed.add(attempt[0])
    return compact(v, f)


def check_manifold(faces, n_vertices, allow_unreferenced=False):
    """Problems as a list of strings (empty = an oriented 2-manifold with boundary)."""
    f = np.asarray(faces, np.int64)
    problems = []
    he = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    if len(np.unique(he, axis=0)) != len(he):
        problems.append("a directed edge is used twice (inconsistent orientation or non-manifold edge)")
    und = np.sort(he, axis=1)
    _, counts = np.unique(und, axis=0, return_counts=True)
    if counts.max() > 2:
        problems.append("an edge has more than two faces")
    if np.any(f[:, 0] == f[:, 1]) or np.any(f[:, 1] == f[:, 2]) or np.any(f[:, 0] == f[:, 2]):
        problems.append("degenerate face")
    # vertex links must be single fans: #boundary half-edges leaving a vertex ≤ 1
    b = boundary_edges(f)
    if len(b) and np.bincount(b[:, 0], minlength=n_vertices).max() > 1:
        problems.append("a boundary vertex is pinched (two openings meet at one vertex)")
    if not allow_unreferenced and len(np.unique(f)) != n_vertices:
        problems.append("unreferenced vertices")
    return problems


def adjacency(faces, n_vertices):
    """Symmetric vertex adjacency (scipy CSR, ones)."""
    from scipy.sparse import coo_matrix
    f = np.asarray(faces, np.int64)
    r = np.concatenate([f[:, 0], f[:, 1], f[:, 2], f[:, 1], f[:, 2], f[:, 0]])
    c = np.concatenate([f[:, 1], f[:, 2], f[:, 0], f[:, 0], f[:, 1], f[:, 2]])
    a = coo_matrix((np.ones(len(r)), (r, c)), shape=(n_vertices, n_vertices)).tocsr()
    a.data[:] = 1.0
    return a


def read_obj(path):
    """Vertices and triangles of an OBJ file (polygons fan-triangulated; texture/normal indices ignored)."""
    verts, faces = [], []
    with open(path) as fh:
        for line in fh:
            parts = line.split()
            if not parts:
                continue
            if parts[0] == "v":
                verts.append([float(p) for p in parts[1:4]])
            elif parts[0] == "f":
                idx = [int(p.split("/")[0]) for p in parts[1:]]
                idx = [i - 1 if i > 0 else len(verts) + i for i in idx]
                for k in range(1, len(idx) - 1):
                    faces.append((idx[0], idx[k], idx[k + 1]))
    return np.array(verts, np.float64), np.array(faces, np.int64)


def write_obj(path, vertices, faces):
    from pleat.fileio import atomic_write
    with atomic_write(path, "w") as fh:
        for p in vertices:
            fh.write(f"v {p[0]:.6f} {p[1]:.6f} {p[2]:.6f}\n")
        for a, b, c in faces:
            fh.write(f"f {a + 1} {b + 1} {c + 1}\n")
