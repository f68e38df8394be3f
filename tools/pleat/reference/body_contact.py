"""The body-contact job (sdk/src/body_contact.c, shaders/body_contact.comp): keep each skinned garment vertex at least
`offset_m` outside the body's tangent plane at the body point nearest to it among its candidates.

The asset carries P body points (asset 1.1: P = N, one per garment vertex): a point r_p on the rest body surface
(shaped by β like the template), the body's unit normal n_p there, and the body's own skin weights at that point.
Per frame each point is posed with those weights, M_p = Σ_k w_pk M_{j_pk} (pose_contact_points):
    a_p = M_p · (r_p, 1),   n_p = normalize(Σ_i (a_{r_i} − a_p) × (a_{r_(i+1) mod m} − a_p))
(asset 1.2, BARG: the posed body's own area-weighted normal, from the ring of posed points r_0..r_(m−1) around p;
without a ring, and in asset 1.1, n_p = normalize(M_p[:, :3] · n_rest)). Why the posed mesh's normal: the blended matrix turns the rest normal
by the joints' rotations only, so near the shoulders, the armpits and the waist, where the skin stretches and folds, it
tilts away from the surface; on the three validation clips with most contact that left 1.27 % of vertex-frames inside
the body with one point per vertex, and candidates did not help (1.25 %); with the posed normal 1.11 % and 0.91 %
with 8 candidates (docs/accuracy.md "Body contact").
Each garment vertex i has up to C candidate points (asset 1.2, BACA; 1.1: its own point). Of the usable ones, those
almost as near to x_i as the nearest blend into one plane, with weights that fall to zero at a margin above the
nearest squared distance m:
    w_c = max(0, (1 + η)·m + ε² − |x − a_c|²),   a = Σ w_c a_c / Σ w_c,   n = normalize(Σ w_c n_c)
    d = (x − a) · n,   x ← x + max(0, offset_m − d) · n
(η = CONTACT_BLEND_SHARE, ε = CONTACT_BLEND_M.) A point with a zero rest normal, or a blended normal of length below
1e-12 (a degenerate blend), is no candidate; a vertex without candidates is left as skinned, and so is one whose
blended normal is shorter than 1e-12. Why several candidates: the garment slides over the body and the arms come down
beside the chest, so the body point nearest a garment vertex changes with the pose; one fixed point per vertex left
vertices inside the body wherever the cloth had moved off its rest neighbour. Why a blend and not the nearest alone:
the nearest jumps from one point to the next as the vertex moves, and so would the push; the blend is continuous in x
(m is), so a vertex never jumps, and two paths that round differently agree to rounding. The narrow margin keeps
nearly all of what the nearest alone removes (docs/accuracy.md "Body contact").
"""
import numpy as np

from pleat.reference.skinning import blend_matrices

MIN_NORMAL_LENGTH = 1e-12
# plDefaultInstanceDef's body_contact_offset_m: a millimetre of clearance, the simulator's contact scale
BODY_CONTACT_OFFSET_M = 0.001
# An empty candidate slot (BACA): the vertex has fewer candidates than the asset's C
NO_CANDIDATE = 0xFFFF
# The blend of candidates almost as near as the nearest (PLEAT_CONTACT_BLEND_SHARE, PLEAT_CONTACT_BLEND_M in kernels.h)
CONTACT_BLEND_SHARE = 0.1
CONTACT_BLEND_M = 0.001
# How far a candidate's plane reaches (the full contact; PLEAT_CONTACT_REACH_* in kernels.h): the whole push where
# the nearest usable candidate is within NEAR, none beyond FAR, linear in the squared distance between
CONTACT_REACH_NEAR_M = 0.03
CONTACT_REACH_FAR_M = 0.05


def contact_reach(nearest_d2):
    """The push's share for vertices whose nearest usable candidate is at squared distance `nearest_d2` (plContactReach:
    a plane centimetres away says little about where the body is; where the cloth had slid far from every candidate,
    pushing out of it drove vertices 4–5 cm into the belly)."""
    near2, far2 = CONTACT_REACH_NEAR_M ** 2, CONTACT_REACH_FAR_M ** 2
    with np.errstate(invalid="ignore"):
        return np.clip((far2 - np.asarray(nearest_d2, np.float64)) / (far2 - near2), 0.0, 1.0)


def pose_contact_points(shaped_points, point_normals, point_skin_indices, point_skin_weights, skin_matrices,
                        point_rings=None):
    """shaped_points / point_normals [P, 3] (rest), point skin [P, K], skin_matrices [J, 3, 4], point_rings [P, R] or
    None → posed points [P, 3], unit normals [P, 3] and whether each point can anchor [P]. A point with a ring (asset
    1.2, BARG: the m ≥ 3 body points around it, counter-clockwise seen from outside, NO_CANDIDATE after them) takes the
    posed body's own area-weighted normal there, Σ_i (x_{r_i} − x_p) × (x_{r_(i+1) mod m} − x_p) (the sum over the
    faces of its closed fan), as the simulator and pleat-eval measure contact; a point without, the blended matrix
    times its rest normal. A point can anchor where its rest normal is non-zero and its normal longer than 1e-12."""
    blended = blend_matrices(point_skin_indices, point_skin_weights, skin_matrices)
    a = np.einsum("nij,nj->ni", blended[..., :3], np.asarray(shaped_points, np.float64)) + blended[..., 3]
    n = np.einsum("nij,nj->ni", blended[..., :3], np.asarray(point_normals, np.float64))
    if point_rings is not None:
        ring = np.asarray(point_rings, np.int64)                               # [P, R]
        m = np.sum(ring < len(a), axis=1)                                       # the used entries are a prefix
        d = a[np.where(ring < len(a), ring, 0)] - a[:, None, :]                 # [P, R, 3]
        following = (np.arange(ring.shape[1])[None, :] + 1) % np.maximum(m, 1)[:, None]
        cross = np.cross(d, np.take_along_axis(d, following[..., None], axis=1))
        cross *= (np.arange(ring.shape[1])[None, :] < m[:, None])[..., None]
        n = np.where((m >= 1)[:, None], cross.sum(axis=1), n)   # (a valid asset has m = 0 or m >= 3)
    length = np.linalg.norm(n, axis=1)
    anchorable = np.any(np.asarray(point_normals) != 0.0, axis=1)
    usable = anchorable & (length > MIN_NORMAL_LENGTH)
    return a, n / np.where(usable, length, 1.0)[:, None], usable


def candidate_weights(positions, posed_points, usable, candidates):
    """positions [N, 3], posed points [P, 3] and their usability [P], candidates [N, C] (NO_CANDIDATE = empty; None =
    the identity, C = 1) → the candidates' point indices [N, C] (0 where empty), their blend weights [N, C] (0 for
    empty slots, unusable points and candidates outside the margin; all 0 for a vertex without candidates) and the
    nearest usable candidate's squared distance [N] (inf without one; the full contact's reach reads it)."""
    x = np.asarray(positions, np.float64)
    N = len(x)
    cand = np.arange(N)[:, None] if candidates is None else np.asarray(candidates, np.int64)
    valid = cand < len(posed_points)
    safe = np.where(valid, cand, 0)
    valid &= usable[safe]
    d2 = np.sum((posed_points[safe] - x[:, None, :]) ** 2, axis=-1)
    m = np.min(np.where(valid, d2, np.inf), axis=1, keepdims=True)
    with np.errstate(invalid="ignore"):
        w = np.maximum(0.0, (1.0 + CONTACT_BLEND_SHARE) * m + CONTACT_BLEND_M ** 2 - d2)
    return safe, np.where(valid, w, 0.0), m[:, 0]


def body_contact(positions, shaped_points, point_normals, point_skin_indices, point_skin_weights, skin_matrices,
                 offset_m, candidates=None, point_rings=None, reach=False):
    """positions [N, 3] (skinned), the body points [P, 3] / [P, 3] / [P, K] / [P, K], skin_matrices [J, 3, 4],
    candidates [N, C] or None (P = N, each vertex its own point) → positions [N, 3] outside the blended tangent plane
    of the nearest candidates by at least offset_m; with `reach` (the full contact) the push scaled by contact_reach
    of the nearest usable candidate's squared distance (the fast contact pushes in full)."""
    x = np.asarray(positions, np.float64)
    a, n, usable = pose_contact_points(shaped_points, point_normals, point_skin_indices, point_skin_weights,
                                       skin_matrices, point_rings)
    index, w, nearest = candidate_weights(x, a, usable, candidates)
    total = w.sum(axis=1)
    has = total > 0.0
    anchor = np.einsum("nc,nci->ni", w, a[index]) / np.where(has, total, 1.0)[:, None]
    normal = np.einsum("nc,nci->ni", w, n[index])
    length = np.linalg.norm(normal, axis=1)
    has &= length > MIN_NORMAL_LENGTH
    normal = normal / np.where(has, length, 1.0)[:, None]
    d = np.einsum("ni,ni->n", x - anchor, normal)
    push = np.where(has & (d < offset_m), offset_m - d, 0.0)
    if reach and candidates is not None:       # a candidate table (asset 1.2); 1.1's one point pushes in full
        push = push * contact_reach(nearest)
    return x + push[:, None] * normal
