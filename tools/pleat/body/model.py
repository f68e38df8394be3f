"""The SMPL-style body used by every Pleat tool: shape blend shapes, joint regressor, 24-joint skeleton, LBS.

Works from `assets/body.npz` (or an SMPL-format file, see `pleat.body.smpl`) with numpy alone; nothing here imports
anny or PyTorch. Frame convention and forward kinematics follow docs/inputs.md:

    G_0 = T(t_root) · Rot(Q_root) · T(J_0) · Rot(R_0)
    G_k = G_parent(k) · T(J_k − J_parent(k)) · Rot(R_k)
    M_k = G_k · T(−J_k)

All methods take arbitrary leading batch dimensions (frames, shapes) and compute in float64.
"""
import numpy as np

from pleat.reference.normals import normals_scatter
from pleat.rotations import quat_to_matrix

SMPL_JOINT_NAMES = (
    "pelvis", "left_hip", "right_hip", "spine1", "left_knee", "right_knee", "spine2", "left_ankle", "right_ankle",
    "spine3", "left_foot", "right_foot", "neck", "left_collar", "right_collar", "head", "left_shoulder",
    "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_hand", "right_hand",
)
SMPL_PARENTS = (-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19, 20, 21)


def _parents_from_kintree(kintree_table):
    """Row 0 of an SMPL kintree_table; the root's parent may be stored as -1 or as 4294967295 (uint32 -1)."""
    row = np.asarray(kintree_table)[0].astype(np.int64)
    row = np.where((row < 0) | (row >= 2 ** 31), -1, row)
    return row


class BodyModel:
    """A linear blend-skinned body with shape blend shapes (SMPL's structure, without pose correctives).

    Attributes (float64 unless said):
      v_template  [V,3]      rest-pose mean body, metres, +Y up, facing +Z
      faces       [F,3] i64  triangles
      shapedirs   [V,3,B]    shape blend shapes; β_b ≈ unit variance
      J_regressor [J,V]      dense joint regressor; J(β) = J_regressor · shaped_vertices(β)
      weights     [V,J]      skinning weights (rows sum to 1)
      parents     [J]   i64  parent index, parents[0] = -1
      joint_names [J]  str
      J_template  [J,3], J_shapedirs [J,3,B]: the regressor applied to v_template and shapedirs (docs/inputs.md)
    """

    def __init__(self, v_template, faces, shapedirs, J_regressor, weights, parents, joint_names=None,
                 pca_variance=None, source=""):
        self.v_template = np.asarray(v_template, dtype=np.float64)
        self.faces = np.asarray(faces, dtype=np.int64)
        self.shapedirs = np.asarray(shapedirs, dtype=np.float64)
        if hasattr(J_regressor, "toarray"):  # scipy sparse
            J_regressor = J_regressor.toarray()
        self.J_regressor = np.asarray(J_regressor, dtype=np.float64)
        self.weights = np.asarray(weights, dtype=np.float64)
        self.parents = np.asarray(parents, dtype=np.int64)
        n_joints = len(self.parents)
        if joint_names is None:
            joint_names = SMPL_JOINT_NAMES if n_joints == 24 else tuple(f"joint{k}" for k in range(n_joints))
        self.joint_names = tuple(str(n) for n in joint_names)
        self.pca_variance = None if pca_variance is None else np.asarray(pca_variance, dtype=np.float64)
        self.source = str(source)
        self._validate()
        self.J_template = self.J_regressor @ self.v_template
        self.J_shapedirs = np.einsum("jv,vcb->jcb", self.J_regressor, self.shapedirs)

    def _validate(self):
        V = self.v_template.shape[0]
        J = len(self.parents)
        if self.v_template.shape != (V, 3):
            raise ValueError(f"v_template must be [V,3], got {self.v_template.shape}")
        if self.shapedirs.ndim != 3 or self.shapedirs.shape[:2] != (V, 3):
            raise ValueError(f"shapedirs must be [V,3,B], got {self.shapedirs.shape}")
        if self.J_regressor.shape != (J, V):
            raise ValueError(f"J_regressor must be [{J},{V}], got {self.J_regressor.shape}")
        if self.weights.shape != (V, J):
            raise ValueError(f"weights must be [{V},{J}], got {self.weights.shape}")
        if self.faces.ndim != 2 or self.faces.shape[1] != 3 or self.faces.min() < 0 or self.faces.max() >= V:
            raise ValueError("faces must be [F,3] with indices in [0, V)")
        if self.parents[0] != -1 or np.any(self.parents[1:] < 0) or np.any(self.parents[1:] >= np.arange(1, J)):
            raise ValueError("parents must have parents[0] = -1 and 0 <= parents[k] < k")
        if len(self.joint_names) != J:
            raise ValueError("joint_names must have one name per joint")

    # ---- sizes -------------------------------------------------------------------------------------------------
    @property
    def num_vertices(self):
        return self.v_template.shape[0]

    @property
    def num_joints(self):
        return len(self.parents)

    @property
    def num_betas(self):
        return self.shapedirs.shape[2]

    def joint_index(self, name):
        return self.joint_names.index(name)

    # ---- loading and saving -------------------------------------------------------------------------------------
    @classmethod
    def from_arrays(cls, arrays, source=None):
        """Build from a mapping with SMPL's keys (v_template, shapedirs, J_regressor, weights, kintree_table, f) or
        Pleat's (faces instead of f, J_regressor as CSR triplet J_regressor_data/indices/indptr, joint_names,
        pca_variance, source)."""
        get = arrays.get if hasattr(arrays, "get") else (lambda k, d=None: arrays[k] if k in arrays else d)
        faces = get("faces")
        if faces is None:
            faces = get("f")
        v_template = np.asarray(get("v_template"))
        J_regressor = get("J_regressor")
        if J_regressor is None and get("J_regressor_data") is not None:
            from scipy.sparse import csr_matrix
            n_joints = np.asarray(get("kintree_table")).shape[1]
            J_regressor = csr_matrix((np.asarray(get("J_regressor_data")), np.asarray(get("J_regressor_indices")),
                                      np.asarray(get("J_regressor_indptr"))),
                                     shape=(n_joints, v_template.shape[0]))
        elif J_regressor is not None and not hasattr(J_regressor, "toarray"):
            J_regressor = np.asarray(J_regressor)
            if J_regressor.dtype == object:  # a pickled scipy matrix inside a 0-d object array
                J_regressor = J_regressor.item()
        shapedirs = np.asarray(get("shapedirs"))
        names = get("joint_names")
        src = get("source")
        return cls(v_template=v_template, faces=np.asarray(faces), shapedirs=shapedirs, J_regressor=J_regressor,
                   weights=np.asarray(get("weights")), parents=_parents_from_kintree(get("kintree_table")),
                   joint_names=None if names is None else [str(n) for n in np.asarray(names).tolist()],
                   pca_variance=get("pca_variance"),
                   source=source if source is not None else ("" if src is None else str(np.asarray(src))))

    @classmethod
    def load(cls, path=None):
        """Load a Pleat body npz (default: assets/body.npz of this checkout)."""
        if path is None:
            path = default_body_path()
        with np.load(path, allow_pickle=False) as z:
            return cls.from_arrays({k: z[k] for k in z.files})

    def kintree_table(self):
        table = np.zeros((2, self.num_joints), dtype=np.int64)
        table[0] = self.parents
        table[1] = np.arange(self.num_joints)
        return table

    # ---- shape -------------------------------------------------------------------------------------------------
    def _betas(self, beta):
        """β [..., b] with b <= B, zero-padded to [..., B] (as SMPL does with fewer betas)."""
        beta = np.zeros(self.num_betas) if beta is None else np.asarray(beta, dtype=np.float64)
        if beta.shape[-1] > self.num_betas:
            raise ValueError(f"beta has {beta.shape[-1]} components, the model {self.num_betas}")
        if beta.shape[-1] < self.num_betas:
            pad = np.zeros(beta.shape[:-1] + (self.num_betas - beta.shape[-1],))
            beta = np.concatenate([beta, pad], axis=-1)
        return beta

    def shaped_vertices(self, beta=None):
        """T + Σ_b β_b S_b → [..., V, 3]."""
        beta = self._betas(beta)
        return self.v_template + np.einsum("vcb,...b->...vc", self.shapedirs, beta)

    def joints(self, beta=None):
        """J(β) = J_regressor · shaped_vertices(β) = J_template + Σ_b β_b J_shapedirs[b] → [..., J, 3]."""
        beta = self._betas(beta)
        return self.J_template + np.einsum("jcb,...b->...jc", self.J_shapedirs, beta)

    # ---- pose --------------------------------------------------------------------------------------------------
    def forward_kinematics(self, local_rotations, root_translation=None, root_rotation=None, beta=None):
        """World joint transforms G [..., J, 4, 4] per docs/inputs.md.

        local_rotations [..., J, 3, 3] (or [..., J, 4] quaternions x,y,z,w); root_translation [..., 3];
        root_rotation [..., 3, 3] or [..., 4]; beta [..., B] or [B]."""
        R = np.asarray(local_rotations, dtype=np.float64)
        if R.shape[-1] == 4:
            R = quat_to_matrix(R)
        if R.shape[-3:] != (self.num_joints, 3, 3):
            raise ValueError(f"local_rotations must be [..., {self.num_joints}, 3, 3], got {R.shape}")
        batch = R.shape[:-3]
        Q = np.eye(3) if root_rotation is None else np.asarray(root_rotation, dtype=np.float64)
        if Q.shape[-1] == 4:
            Q = quat_to_matrix(Q)
        t = np.zeros(3) if root_translation is None else np.asarray(root_translation, dtype=np.float64)
        J = self.joints(beta)
        batch = np.broadcast_shapes(batch, Q.shape[:-2], t.shape[:-1], J.shape[:-2])
        R = np.broadcast_to(R, batch + R.shape[-3:])
        J = np.broadcast_to(J, batch + J.shape[-2:])
        rot = np.empty(batch + (self.num_joints, 3, 3))
        pos = np.empty(batch + (self.num_joints, 3))
        rot[..., 0, :, :] = Q @ R[..., 0, :, :]
        pos[..., 0, :] = t + np.einsum("...ij,...j->...i", Q, J[..., 0, :])
        for k in range(1, self.num_joints):
            p = self.parents[k]
            rot[..., k, :, :] = rot[..., p, :, :] @ R[..., k, :, :]
            pos[..., k, :] = pos[..., p, :] + np.einsum("...ij,...j->...i", rot[..., p, :, :], J[..., k, :] - J[..., p, :])
        G = np.zeros(batch + (self.num_joints, 4, 4))
        G[..., :3, :3] = rot
        G[..., :3, 3] = pos
        G[..., 3, 3] = 1.0
        return G

    def skinning_matrices(self, G, beta=None):
        """M_k = G_k · T(−J_k) → [..., J, 4, 4]: rest space → world."""
        J = self.joints(beta)
        M = G.copy()
        M[..., :3, 3] = G[..., :3, 3] - np.einsum("...kij,...kj->...ki", G[..., :3, :3], J)
        return M

    def skin(self, local_rotations, root_translation=None, root_rotation=None, beta=None, return_joints=False):
        """Posed vertices [..., V, 3] by linear blend skinning of shaped_vertices(β)."""
        G = self.forward_kinematics(local_rotations, root_translation, root_rotation, beta)
        M = self.skinning_matrices(G, beta)
        v = self.shaped_vertices(beta)
        A = np.einsum("vk,...kij->...vij", self.weights, M[..., :3, :])  # per-vertex blended [3,4]
        posed = np.einsum("...vij,...vj->...vi", A[..., :3], v) + A[..., 3]
        if return_joints:
            return posed, G[..., :3, 3]
        return posed

    def rest_pose(self, batch=()):
        """Identity local rotations [*batch, J, 3, 3]."""
        return np.broadcast_to(np.eye(3), tuple(batch) + (self.num_joints, 3, 3)).copy()


# Area-weighted unit vertex normals [..., V, 3]: the runtime's normals (face normals added to their vertices in face
# order), defined once in pleat.reference.normals for the body, the garments and the simulator's collider alike.
vertex_normals = normals_scatter


class BodyCollider:
    """Closest point and signed distance to a posed body surface: the simulator's contact, the garment generator's
    offsets and every "inside the body" test use this one class.

    A cKDTree over the posed body's vertices plus their area-weighted normals: the nearest body *vertex* p (normal n)
    stands in for the closest surface point. Both distances below are signed the same way — negative inside, i.e.
    behind the tangent plane at p, (x − p)·n < 0 — and differ only in magnitude:

    - `query`, `plane_distance`, `distance_to`: (x − p)·n, the distance to the tangent plane at p (HOOD's vertex-based
      test; what the simulator's contact uses). Exact over a flat patch and within a few tenths of a millimetre of the
      true distance on the smooth 13k-vertex body at the sub-centimetre distances that matter for contact
      (docs/simulator.md).
    - `signed_distance`: |x − p| with that sign, which over-estimates the distance to the surface by at most the
      circumradius of the triangles around p (about half an edge: ≈ 5 mm on the torso and limbs of the shipped body,
      < 2 mm on hands and face); `k > 1` refines it with the tangent planes of the k nearest vertices (≈ 1 mm near the
      surface).

    The sign is reliable wherever the point is closer to the surface than the local radius of curvature; in deep
    creases (armpit, crotch, between the legs when they touch) a point can be classified against the wrong side.
    """

    def __init__(self, vertices, faces, collide=None):
        """`collide` (bool [V], optional): the body vertices the garment collides with; the others are not found
        by any query (the indices returned are still the whole body's). A skirt leaves out the hands and forearms
        (`Garment.collision_exclude`): a vertex-based contact cannot tell which side of a thin part a cloth vertex
        belongs on, so a swinging hand that reaches the skirt carries it along instead of brushing past."""
        from scipy.spatial import cKDTree
        self.vertices = np.asarray(vertices, dtype=np.float64)
        self.faces = np.asarray(faces, dtype=np.int64)
        self.normals = vertex_normals(self.vertices, self.faces)
        self.collide = None if collide is None else np.asarray(collide, bool)
        self._ids = None if self.collide is None else np.flatnonzero(self.collide)
        self.tree = cKDTree(self.vertices if self._ids is None else self.vertices[self._ids])

    @classmethod
    def lerp(cls, a, b, s):
        """The body a fraction s of the way from collider a to collider b (vertices interpolated linearly)."""
        return cls((1.0 - s) * a.vertices + s * b.vertices, a.faces, a.collide)

    def _nearest(self, points, k=1):
        d, idx = self.tree.query(np.asarray(points, dtype=np.float64), k=k)
        return d, (idx if self._ids is None else self._ids[idx])

    def closest_vertex(self, points):
        return self._nearest(points)

    def query(self, x):
        """For points x [P, 3]: nearest vertex index, its position p, its normal n and (x − p)·n."""
        _, idx = self._nearest(x)
        p = self.vertices[idx]
        n = self.normals[idx]
        d = np.einsum("ij,ij->i", x - p, n)
        return idx, p, n, d

    def distance_to(self, x, idx):
        """Signed distance of x to the tangent planes of the given body vertices (one per point)."""
        return np.einsum("ij,ij->i", x - self.vertices[idx], self.normals[idx])

    def plane_distance(self, x):
        """(x − p)·n for the nearest vertex p of each point [P] (metres, negative inside)."""
        return self.query(x)[3]

    def signed_distance(self, points, k=1):
        """Signed distance [...] (metres, negative inside), index of the closest vertex, and its normal."""
        p = np.asarray(points, dtype=np.float64)
        d, idx = self._nearest(p, k=max(1, k))
        if k <= 1:
            idx0 = idx
            diff = p - self.vertices[idx0]
            sign = np.where(np.sum(diff * self.normals[idx0], axis=-1) < 0, -1.0, 1.0)
            return sign * d, idx0, self.normals[idx0]
        idx0 = idx[..., 0]
        diff = p[..., None, :] - self.vertices[idx]                      # [..., k, 3]
        n = self.normals[idx]
        plane = np.sum(diff * n, axis=-1)                               # distances to the k tangent planes
        sign = np.where(plane[..., 0] < 0, -1.0, 1.0)
        # the surface is at least as far as the nearest tangent plane and at most as far as the nearest vertex
        weights = 1.0 / np.maximum(d, 1e-9)
        plane_d = np.sum(weights * np.abs(plane), axis=-1) / np.sum(weights, axis=-1)
        mag = np.minimum(d[..., 0], plane_d)
        return sign * mag, idx0, self.normals[idx0]

    def push_out(self, points, clearance, iterations):
        """A copy of points [P, 3] where those closer than clearance to the body (signed_distance with k = 8; inside
        included) are moved out along the body normal, repeated up to `iterations` times while any is."""
        x = np.array(points, dtype=np.float64)
        for _ in range(iterations):
            d, _, n = self.signed_distance(x, k=8)
            low = d < clearance
            if not low.any():
                break
            x[low] += (clearance - d[low])[:, None] * n[low]
        return x

    def inside(self, points, tolerance=0.0):
        """True where a point is deeper than `tolerance` metres inside the body."""
        return self.signed_distance(points)[0] < -tolerance


def default_body_path():
    from pleat.paths import BODY_PATH
    return BODY_PATH
