"""The body-contact job (sdk/src/body_contact.c, shaders/body_contact.comp): keep each skinned garment vertex at least
`offset_m` outside the body's tangent plane at its anchor.

Each garment vertex i has a body anchor: a point a_i on the rest body surface (shaped by β like the template), the
body's unit normal n_i there, and the body's own skin weights at that point. Per frame the anchor is skinned with
those weights, M_a = Σ_k w_ik M_{j_ik}:
    a = M_a · (a_i, 1),   n = normalize(M_a[:, :3] · n_i),   d = (x − a) · n
    x ← x + max(0, offset_m − d) · n
A zero rest normal means the vertex has no anchor (left as skinned), and so does a blended normal of length below
1e-12 (a degenerate blend). Continuous in x, so a vertex never jumps when it starts or stops touching.
"""
import numpy as np

from pleat.reference.skinning import blend_matrices

MIN_NORMAL_LENGTH = 1e-12
# plDefaultInstanceDef's body_contact_offset_m: a millimetre of clearance, the simulator's contact scale
BODY_CONTACT_OFFSET_M = 0.001


def body_contact(positions, shaped_anchors, anchor_normals, anchor_skin_indices, anchor_skin_weights, skin_matrices,
                 offset_m):
    """positions [N, 3] (skinned), shaped_anchors / anchor_normals [N, 3] (rest), anchor skin [N, K], skin_matrices
    [J, 3, 4] → positions [N, 3] outside the anchors' tangent planes by at least offset_m."""
    x = np.asarray(positions, np.float64)
    blended = blend_matrices(anchor_skin_indices, anchor_skin_weights, skin_matrices)
    a = np.einsum("nij,nj->ni", blended[..., :3], np.asarray(shaped_anchors, np.float64)) + blended[..., 3]
    n = np.einsum("nij,nj->ni", blended[..., :3], np.asarray(anchor_normals, np.float64))
    length = np.linalg.norm(n, axis=1)
    has_anchor = length > MIN_NORMAL_LENGTH
    n = n / np.where(has_anchor, length, 1.0)[:, None]
    d = np.einsum("ni,ni->n", x - a, n)
    push = np.where(has_anchor & (d < offset_m), offset_m - d, 0.0)
    return x + push[:, None] * n
