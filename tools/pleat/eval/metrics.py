"""Per-clip error metrics between a predicted garment sequence and the reference simulation.

All sequences are [T, N, 3] arrays in metres sampled at the same frames; results are in mm (distances) and m/s²
(accelerations). The same functions score Pleat, the LBS-only baseline and the stage-1 teacher, so their numbers are
comparable by construction.
"""
import numpy as np


def vertex_error_mm(pred, ref):
    """Per-vertex Euclidean distance for every frame, [T, N], in mm."""
    pred, ref = np.asarray(pred, np.float64), np.asarray(ref, np.float64)
    if pred.shape != ref.shape:
        raise ValueError(f"shape mismatch: {pred.shape} vs {ref.shape}")
    return np.linalg.norm(pred - ref, axis=-1) * 1000.0


def edge_strain(positions, edges, rest_lengths):
    """Relative stretch l/l0 − 1 of every edge in every frame, [T, E]."""
    p = np.asarray(positions, np.float64)
    lengths = np.linalg.norm(p[:, edges[:, 1]] - p[:, edges[:, 0]], axis=-1)
    return lengths / rest_lengths - 1.0


def acceleration(positions, dt_s):
    """Second finite difference per vertex, [T−2, N, 3], in m/s²."""
    p = np.asarray(positions, np.float64)
    return (p[2:] - 2.0 * p[1:-1] + p[:-2]) / (dt_s * dt_s)


def unique_edges(faces):
    f = np.asarray(faces, np.int64)
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    e.sort(axis=1)
    return np.unique(e, axis=0)


def penetration(signed_distance_m):
    """Share of garment vertices inside the body (signed distance < 0), in %, and the deepest, in mm.

    signed_distance_m: [T, N], negative inside the body."""
    d = np.asarray(signed_distance_m, np.float64)
    inside = d < 0.0
    return {
        "penetration_pct": float(100.0 * inside.mean()),
        "max_depth_mm": float(max(0.0, -d.min()) * 1000.0),
        "per_frame_pct": (100.0 * inside.mean(axis=1)).tolist(),
    }


def score(pred, ref, faces, rest_positions, dt_s, signed_distance_m=None):
    """The numbers pleat-eval reports for one method on one clip."""
    err = vertex_error_mm(pred, ref)
    edges = unique_edges(faces)
    rest = np.asarray(rest_positions, np.float64)
    rest_lengths = np.linalg.norm(rest[edges[:, 1]] - rest[edges[:, 0]], axis=-1)
    strain_err = np.abs(edge_strain(pred, edges, rest_lengths) - edge_strain(ref, edges, rest_lengths))
    out = {
        "mean_mm": float(err.mean()),
        "p95_mm": float(np.percentile(err, 95)),
        "per_frame_mean_mm": err.mean(axis=1).tolist(),
        "edge_strain_error": float(strain_err.mean()),
        # Jitter: how far the method's vertex accelerations are from the reference's (m/s², mean over vertices/frames).
        "jitter": float(np.linalg.norm(acceleration(pred, dt_s) - acceleration(ref, dt_s), axis=-1).mean())
        if len(pred) >= 3 else 0.0,
    }
    if signed_distance_m is not None:
        out.update(penetration(signed_distance_m))
    return out


def score_regions(pred, ref, faces, rest_positions, regions, signed_distance_m=None):
    """score's numbers restricted to each garment region (pleat.eval.regions): {name: {...}}.

    regions: {name: bool [N]}. Per region: `vertices`, mean_mm / p95_mm over the region's vertices and all frames,
    edge_strain_error over the edges with both ends in the region (`edges`: how many; null when none), and, with
    signed distances, penetration_pct over the region's vertices. An empty region (a user's mesh under a known
    garment name, cut differently) reports its zero count and nulls, never NaN."""
    err = vertex_error_mm(pred, ref)
    edges = unique_edges(faces)
    rest = np.asarray(rest_positions, np.float64)
    rest_lengths = np.linalg.norm(rest[edges[:, 1]] - rest[edges[:, 0]], axis=-1)
    strain_err = np.abs(edge_strain(pred, edges, rest_lengths) - edge_strain(ref, edges, rest_lengths))
    d = None if signed_distance_m is None else np.asarray(signed_distance_m, np.float64)
    out = {}
    for name, mask in regions.items():
        m = np.asarray(mask, bool)
        inner = m[edges[:, 0]] & m[edges[:, 1]]
        r = {"vertices": int(m.sum()), "edges": int(inner.sum()), "mean_mm": None, "p95_mm": None,
             "edge_strain_error": None}
        if m.any():
            e = err[:, m]
            r.update(mean_mm=float(e.mean()), p95_mm=float(np.percentile(e, 95)))
        if inner.any():
            r["edge_strain_error"] = float(strain_err[:, inner].mean())
        if d is not None:
            r["penetration_pct"] = float(100.0 * (d[:, m] < 0.0).mean()) if m.any() else None
        out[str(name)] = r
    return out
