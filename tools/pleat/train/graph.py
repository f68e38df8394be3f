"""Garment graph structures built once per garment (numpy): mesh edges, HOOD-style coarsened levels and the
down-sampling hierarchy of the mesh-convolution compressor (Zhou et al. 2020)."""
import numpy as np
from scipy.spatial import cKDTree


def mesh_edges(faces, n):
    """Undirected edges (i < j) of a triangle mesh, sorted."""
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    e = np.sort(e, axis=1)
    e = np.unique(e, axis=0)
    assert e.max() < n
    return e


def _adjacency(edges, n):
    adj = [[] for _ in range(n)]
    for a, b in edges:
        adj[a].append(b)
        adj[b].append(a)
    return adj


def coarsen(edges, vertices, n, seed=0):
    """One HOOD coarsening step: a maximal independent set S of the level graph (vertices `vertices`), and the coarse
    edges joining members of S that are two hops apart in the finer level."""
    adj = _adjacency(edges, n)
    rng = np.random.default_rng(seed)
    order = rng.permutation(vertices)
    state = np.zeros(n, dtype=np.int8)  # 0 free, 1 chosen, 2 blocked
    for v in order:
        if state[v] == 0:
            state[v] = 1
            for u in adj[v]:
                state[u] = 2
    chosen = np.sort(np.asarray([v for v in vertices if state[v] == 1], dtype=np.int64))
    coarse = set()
    for v in chosen:
        for u in adj[v]:
            for w in adj[u]:
                if w != v and state[w] == 1:
                    coarse.add((min(v, w), max(v, w)))
    ce = np.array(sorted(coarse), dtype=np.int64).reshape(-1, 2)
    return chosen, ce


def build_hierarchy(faces, n, levels, seed=0):
    """Message-passing levels: list of (vertex ids, undirected edges); level 0 is the mesh itself."""
    edges = mesh_edges(faces, n)
    out = [(np.arange(n), edges)]
    for l in range(1, levels):
        verts, edges = coarsen(out[-1][1], out[-1][0], n, seed + l)
        out.append((verts, edges))
    vertex_level = np.zeros(n, dtype=np.int64)
    for l, (verts, _) in enumerate(out):
        vertex_level[verts] = l
    return out, vertex_level


def compressor_hierarchy(template, faces, steps, neighbours, seed=0):
    """Down-sampling chain for the spatially varying mesh convolution: for each step the kept vertex subset (indices
    into the previous step's vertex list) and, per kept vertex, its `neighbours` nearest vertices of the previous
    step (template distance), as Zhou et al. define a convolution's receptive field on the sampled mesh."""
    n = len(template)
    edges = mesh_edges(faces, n)
    current = np.arange(n)
    chain = []
    for s in range(steps):
        kept, edges = coarsen(edges, current, n, seed + 101 + s)
        if len(kept) < 2:
            break
        tree = cKDTree(template[current])
        k = min(neighbours, len(current))
        _, nbr = tree.query(template[kept], k=k)
        nbr = nbr.reshape(len(kept), k)
        chain.append(nbr.astype(np.int64))
        current = kept
    return chain, current
