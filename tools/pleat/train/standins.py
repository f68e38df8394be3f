"""Small stand-ins for the body, motion and garment modules, used only while those modules are missing.

They follow the interfaces the real modules implement (SMPL joint names and parents, a Clip with fps and local
quaternions, a garment with template/faces/skin/shape_blend/pinned) at toy scale, so that training can be developed and
tested before the other packages land. Kinematics, X_c and the energies are never stood in for: training always uses
pleat.reference and pleat.physics. `pleat.train.sources` picks the real module whenever it imports and falls back to these
otherwise; the run's config records which one was used (`sources` key), so no asset is shipped from a stand-in
without saying so.
"""
import numpy as np

from pleat import rotations as rot

SMPL_JOINT_NAMES = [
    "pelvis", "left_hip", "right_hip", "spine1", "left_knee", "right_knee", "spine2", "left_ankle", "right_ankle",
    "spine3", "left_foot", "right_foot", "neck", "left_collar", "right_collar", "head", "left_shoulder",
    "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_hand", "right_hand"]
SMPL_PARENTS = np.array([-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19, 20, 21])
# T-pose joint locations (m), +Y up, facing +Z, pelvis near the origin as SMPL has it.
_JOINTS = np.array([
    [0, 0, 0], [0.09, -0.08, 0], [-0.09, -0.08, 0], [0, 0.11, -0.01], [0.10, -0.46, 0], [-0.10, -0.46, 0],
    [0, 0.24, 0], [0.10, -0.86, -0.03], [-0.10, -0.86, -0.03], [0, 0.30, 0.01], [0.11, -0.91, 0.09],
    [-0.11, -0.91, 0.09], [0, 0.52, -0.01], [0.07, 0.43, 0], [-0.07, 0.43, 0], [0, 0.62, 0.04], [0.18, 0.45, -0.01],
    [-0.18, 0.45, -0.01], [0.44, 0.45, -0.02], [-0.44, 0.45, -0.02], [0.68, 0.45, -0.01], [-0.68, 0.45, -0.01],
    [0.76, 0.45, -0.01], [-0.76, 0.45, -0.01]], dtype=np.float64)
# Capsule radius per bone (indexed by child joint).
_RADIUS = np.array([0.0, 0.08, 0.08, 0.12, 0.06, 0.06, 0.13, 0.05, 0.05, 0.13, 0.04, 0.04, 0.05, 0.06, 0.06,
                    0.09, 0.05, 0.05, 0.04, 0.04, 0.03, 0.03, 0.03, 0.03])


class StandinBody:
    """Capsules around the bones of an SMPL-shaped stick figure, with the BodyModel attributes training reads."""

    def __init__(self, samples_per_bone=160, seed=0):
        rng = np.random.default_rng(seed)
        self.joint_names = list(SMPL_JOINT_NAMES)
        self.parents = SMPL_PARENTS.copy()
        verts, normals, bone = [], [], []
        for k in range(1, 24):
            a, b, r = _JOINTS[self.parents[k]], _JOINTS[k], _RADIUS[k]
            axis = b - a
            length = np.linalg.norm(axis)
            u = axis / length
            t1 = np.cross(u, [0.0, 0.0, 1.0] if abs(u[2]) < 0.9 else [1.0, 0.0, 0.0])
            t1 /= np.linalg.norm(t1)
            t2 = np.cross(u, t1)
            s = rng.uniform(0, 1, samples_per_bone)
            phi = rng.uniform(0, 2 * np.pi, samples_per_bone)
            n = np.cos(phi)[:, None] * t1 + np.sin(phi)[:, None] * t2
            verts.append(a + s[:, None] * axis + r * n)
            normals.append(n)
            bone.append(np.full(samples_per_bone, self.parents[k]))
        self.v_template = np.concatenate(verts)
        self.vertex_normals_rest = np.concatenate(normals)
        bone = np.concatenate(bone)
        self.weights = np.zeros((len(self.v_template), 24))
        self.weights[np.arange(len(bone)), bone] = 1.0
        # Smooth shape directions: height, girth and a few low-frequency bumps, roughly unit-variance scaled.
        v = self.v_template
        dirs = np.zeros((len(v), 3, 10))
        dirs[:, 1, 0] = 0.03 * v[:, 1]
        dirs[:, :, 1] = 0.02 * self.vertex_normals_rest
        for b in range(2, 10):
            f = rng.normal(size=3) * 3
            dirs[:, :, b] = 0.004 * np.sin(v @ f)[:, None] * self.vertex_normals_rest
        self.shapedirs = dirs
        jdirs = np.zeros((10, 24, 3))
        jdirs[0, :, 1] = 0.03 * _JOINTS[:, 1]
        # Joint markers appended after the surface so that a J_regressor (one-hot on them) gives J(β) as the real
        # body's regressor does; collisions use the surface only.
        self.collision_vertex_count = len(self.v_template)
        self.v_template = np.concatenate([self.v_template, _JOINTS])
        self.vertex_normals_rest = np.concatenate([self.vertex_normals_rest, np.zeros((24, 3))])
        self.shapedirs = np.concatenate([self.shapedirs, np.moveaxis(jdirs, 0, -1)])
        self.weights = np.concatenate([self.weights, np.eye(24)])
        self.J_regressor = np.zeros((24, len(self.v_template)))
        self.J_regressor[np.arange(24), self.collision_vertex_count + np.arange(24)] = 1.0
        self.faces = np.zeros((0, 3), dtype=np.int64)
        self.source = "pleat.train.standins capsule body (stand-in)"

    def shaped_vertices(self, beta):
        return self.v_template + self.shapedirs @ np.asarray(beta, dtype=np.float64)


class StandinClip:
    def __init__(self, name, fps, rotations, root_translation, root_rotation):
        self.name, self.fps = name, fps
        self.rotations, self.root_translation, self.root_rotation = rotations, root_translation, root_rotation


def standin_clips(fps=30.0, frames=120, count=3, seed=0):
    """Procedural walks/turns/arm swings: smooth, periodic, with a moving and turning root."""
    rng = np.random.default_rng(seed)
    clips = []
    for c in range(count):
        t = np.arange(frames) / fps
        freq = rng.uniform(0.7, 1.4)
        ph = 2 * np.pi * freq * t
        aa = np.zeros((frames, 24, 3))
        amp = rng.uniform(0.3, 0.8)
        aa[:, 1, 0], aa[:, 2, 0] = amp * np.sin(ph), -amp * np.sin(ph)
        aa[:, 4, 0], aa[:, 5, 0] = amp * (1 + np.cos(ph)) * 0.5, amp * (1 - np.cos(ph)) * 0.5
        aa[:, 16, 2] = -1.1 + 0.4 * np.sin(ph * rng.uniform(0.5, 2.0))
        aa[:, 17, 2] = 1.1 - 0.4 * np.sin(ph * rng.uniform(0.5, 2.0))
        aa[:, 16, 1], aa[:, 17, 1] = -0.4 * np.sin(ph), -0.4 * np.sin(ph)
        aa[:, 3, 1] = 0.15 * np.sin(ph)
        aa[:, 6, 0] = 0.1 * np.sin(2 * ph)
        turn = rng.uniform(-0.6, 0.6)
        yaw = turn * t
        speed = rng.uniform(0.5, 1.6)
        root_t = np.zeros((frames, 3))
        root_t[:, 0] = np.cumsum(speed * np.sin(yaw)) / fps
        root_t[:, 2] = np.cumsum(speed * np.cos(yaw)) / fps
        root_t[:, 1] = 0.93 + 0.03 * np.sin(2 * ph)
        root_q = np.stack([np.zeros(frames), np.sin(yaw / 2), np.zeros(frames), np.cos(yaw / 2)], -1)
        quats = rot.matrix_to_quat(rot.axis_angle_to_matrix(aa))
        clips.append(StandinClip(f"standin_{c}", fps, quats, root_t, root_q))
    return clips


class StandinGarment:
    """A closed-around-the-torso tube (a sleeveless top) with diffused skinning and shape blends from the body."""

    def __init__(self, body, vertices=400):
        rings = max(6, int(round(np.sqrt(vertices / 2.5))))
        seg = max(8, int(round(vertices / rings)))
        y = np.linspace(-0.12, 0.42, rings)
        ang = np.linspace(0, 2 * np.pi, seg, endpoint=False)
        rx = 0.19 - 0.03 * np.cos(np.linspace(0, np.pi, rings))
        rz = 0.15 - 0.01 * np.cos(np.linspace(0, np.pi, rings))
        self.template = np.stack([(rx[:, None] * np.sin(ang)[None]).ravel(), np.repeat(y, seg),
                                  (rz[:, None] * np.cos(ang)[None]).ravel()], -1)
        faces = []
        for r in range(rings - 1):
            for s in range(seg):
                a, b = r * seg + s, r * seg + (s + 1) % seg
                c, d = a + seg, b + seg
                faces += [[a, b, d], [a, d, c]]
        self.faces = np.array(faces, dtype=np.int64)
        self.name = "standin_top"
        # Diffusion, as HOOD: nearest body vertices' skin weights and shape directions.
        from scipy.spatial import cKDTree
        _, idx = cKDTree(body.v_template).query(self.template, k=8)
        w = body.weights[idx].mean(1)
        order = np.argsort(-w, axis=1)[:, :4]
        sw = np.take_along_axis(w, order, 1)
        self.skin_indices = order
        self.skin_weights = sw / sw.sum(1, keepdims=True)
        self.shape_blend = np.moveaxis(body.shapedirs[idx].mean(1), -1, 0)  # [10,N,3]
        self.pinned = np.zeros(0, dtype=np.int64)
