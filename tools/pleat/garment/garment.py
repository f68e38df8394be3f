"""The Garment object and its npz file (what pleat-garment writes, the simulator, training and packing read)."""
from dataclasses import dataclass, field, fields

import numpy as np

from ..fileio import save_npz
from ..physics.energies import cloth_rest
from ..physics.materials import MATERIAL_DEFAULT


@dataclass
class Garment:
    name: str
    template: np.ndarray          # [N, 3] f32, rest pose on the template body (β = 0), metres
    faces: np.ndarray             # [F, 3] i32, outward
    skin_indices: np.ndarray      # [N, 4] i32, body joints, largest weight first
    skin_weights: np.ndarray      # [N, 4] f32, rows sum to 1
    shape_blend: np.ndarray       # [10, N, 3] f32, G_S: T + Σ_b β_b shape_blend[b]
    pinned: np.ndarray            # [P] i32, vertices that follow the body by LBS in the simulator
    edges: np.ndarray             # [E, 2] i32 unique edges
    rest_edge_length: np.ndarray  # [E] f32, m
    vertex_area: np.ndarray       # [N] f32, a third of the adjacent rest area, m²
    vertex_mass: np.ndarray       # [N] f32, kg, at the default areal density MATERIAL_DEFAULT[0]
    # [X] i32 body joints whose vertices the garment does not collide with (empty: the whole body). Optional in the
    # npz: files written before it existed collide with the whole body, as they did.
    collision_exclude: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))

    @classmethod
    def build(cls, name, template, faces, skin_indices, skin_weights, shape_blend, pinned, collision_exclude=()):
        rest = cloth_rest(template, faces)
        return cls(name=str(name), template=np.asarray(template, np.float32), faces=np.asarray(faces, np.int32),
                   skin_indices=np.asarray(skin_indices, np.int32), skin_weights=np.asarray(skin_weights, np.float32),
                   shape_blend=np.asarray(shape_blend, np.float32), pinned=np.asarray(pinned, np.int32),
                   edges=rest.edges.astype(np.int32), rest_edge_length=rest.edge_length.astype(np.float32),
                   vertex_area=rest.vertex_area.astype(np.float32),
                   vertex_mass=(MATERIAL_DEFAULT[0] * rest.vertex_area).astype(np.float32),
                   collision_exclude=np.asarray(collision_exclude, np.int32).reshape(-1))

    def body_collision_mask(self, body):
        return body_collision_mask(self.collision_exclude, body)

    @property
    def num_vertices(self):
        return len(self.template)

    def shaped(self, beta=None):
        """T + Σ_b β_b G_S[b] → [N, 3] float64."""
        t = self.template.astype(np.float64)
        if beta is None:
            return t
        beta = np.asarray(beta, np.float64)
        return t + np.einsum("b,bnc->nc", beta, self.shape_blend[:len(beta)].astype(np.float64))

    def skin(self, skinning_matrices, beta=None):
        """LBS of the shaped template with body skinning matrices M [..., J, 4, 4] → [..., N, 3]."""
        x = self.shaped(beta)
        M = np.asarray(skinning_matrices, np.float64)[..., self.skin_indices, :3, :]   # [..., N, K, 3, 4]
        A = np.einsum("nk,...nkij->...nij", self.skin_weights.astype(np.float64), M)
        return np.einsum("...nij,nj->...ni", A[..., :3], x) + A[..., 3]

    def save(self, path):
        return save_npz(path, compressed=True, **{f.name: np.asarray(getattr(self, f.name)) for f in fields(self)})

    @classmethod
    def load(cls, path):
        with np.load(path, allow_pickle=False) as z:
            return cls(**{f.name: (str(z[f.name]) if f.name == "name" else z[f.name]) for f in fields(cls)
                          if f.name in z.files or f.name != "collision_exclude"})


def body_collision_mask(collision_exclude, body):
    """bool [V]: the body vertices a garment collides with (those whose largest skin weight is on a joint not in
    collision_exclude), or None for the whole body. The simulator's contact, the runtime's contact candidates and
    the penetration measure all use it, so a garment is never pushed, nor scored, against a part it passes through."""
    if collision_exclude is None or len(collision_exclude) == 0:
        return None
    weights = body["weights"] if isinstance(body, dict) else body.weights
    return ~np.isin(np.argmax(np.asarray(weights), axis=1), np.asarray(collision_exclude))
