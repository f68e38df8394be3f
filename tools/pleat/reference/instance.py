"""The numpy twin of the C instance (plInstance): pose history, latent, clamps and guards of docs/inputs.md."""
import numpy as np

from pleat.asset import normal_adjacency
from pleat.reference.blend_shapes import blend_shapes, shape_blend
from pleat.reference.forward_kinematics import shaped_joints
from pleat.reference.input_assembly import (clamp_beta, clamp_dt, clamp_material, input_assembly,
                                            normalize_quaternions, pose_features)
from pleat.reference.mlp import layers, mlp
from pleat.reference.normals import normals
from pleat.reference.skinning import skinning

RESULT_OK, RESULT_CLAMPED, RESULT_NUMERIC_RESET = "ok", "clamped", "numeric_reset"


class StepError(ValueError):
    """A rejected input; `code` is the matching C result name (NON_FINITE_INPUT, INVALID_DT, INVALID_QUATERNION,
    JOINT_COUNT_MISMATCH). The instance is unchanged."""

    def __init__(self, message, code):
        super().__init__(message)
        self.code = code


class Instance:
    """Instance(asset, beta, material). asset: dict from pleat.asset.read_asset (or a validated weights dict).
    step(rotations [J, 4], root_translation [3], root_rotation [4], dt_s) → (positions [N, 3], normals [N, 3]).
    `last_result` is "ok", "clamped" or "numeric_reset" after each call that changes state."""

    def __init__(self, asset, beta=None, material=None, network_rate_hz=0.0):
        self.asset = asset
        self.parents = np.asarray(asset["joint_parents"], np.int64)
        self.input_joints = np.asarray(asset["input_joints"], np.int64)
        self.faces = np.asarray(asset["faces"], np.int64)
        self.skin_indices = np.asarray(asset["skin_indices"], np.int64)
        self.skin_weights = np.asarray(asset["skin_weights"], np.float64)
        self.blend = np.asarray(asset["blend_shapes"], np.float64)
        self.adjacency_offsets, self.adjacency_faces = normal_adjacency(self.faces, self.blend.shape[1])
        self.lp_weights, self.lp_biases = layers(asset, "lp")
        self.dec_weights, self.dec_biases = layers(asset, "dec")
        self.lp_activation = str(asset["lp_activation"])
        self.dec_activation = str(asset["dec_activation"])
        f64 = lambda k: np.asarray(asset[k], np.float64)
        self.x_mean, self.x_std = f64("x_mean"), f64("x_std")
        self.z_mean, self.z_std, self.z_min, self.z_max = f64("z_mean"), f64("z_std"), f64("z_min"), f64("z_max")
        self.joint_count = len(self.parents)
        self.latent_count = len(self.z_mean)
        self.last_result = RESULT_OK
        self.set_shape(beta)
        self.set_material(material)
        self.set_network_rate(network_rate_hz)
        self.reset()

    def set_shape(self, beta):
        """Clamps β and recomputes the shaped template and joints. Returns True if β was clamped."""
        self.beta, clamped = clamp_beta(self.asset, beta)
        self.shaped_template = shape_blend(self.asset["template"], self.asset["shape_blend"], self.beta)
        self.joints = shaped_joints(self.asset["joint_template"], self.asset["joint_shapedirs"], self.beta)
        return clamped

    def set_material(self, material):
        """Clamps the material (m, μ, λ, k). Returns True if it was clamped."""
        self.material, self.material_normalised, clamped = clamp_material(self.asset, material)
        return clamped

    def set_network_rate(self, network_rate_hz):
        """Run the networks at most this often (Hz; 0 = every step), as plInstanceDef.network_rate_hz."""
        rate = float(network_rate_hz)
        if not (np.isfinite(rate) and rate >= 0.0):
            raise ValueError("network_rate_hz: must be finite and >= 0")
        self.network_interval = 1.0 / rate if rate > 0.0 else 0.0

    def reset(self):
        self.latent = np.zeros(self.latent_count)
        self.history = None        # pose features of frames t and t−1, and dt_t
        self.skin_matrices = None
        self.network_pending = 0.0  # time since the last network update

    def _validate(self, rotations, root_translation, root_rotation, dt_s):
        rotations = np.asarray(rotations, np.float64)
        if rotations.shape != (self.joint_count, 4):
            raise StepError(f"rotations: expected [{self.joint_count}, 4], got {rotations.shape}",
                            "JOINT_COUNT_MISMATCH")
        root_translation = np.asarray(root_translation, np.float64).reshape(3)
        root_rotation = np.asarray(root_rotation, np.float64).reshape(4)
        if not (np.all(np.isfinite(rotations)) and np.all(np.isfinite(root_translation))
                and np.all(np.isfinite(root_rotation)) and np.isfinite(dt_s)):
            raise StepError("non-finite input", "NON_FINITE_INPUT")
        try:
            rotations = normalize_quaternions(rotations)
            root_rotation = normalize_quaternions(root_rotation, zero_is_identity=True)
        except ValueError as e:
            raise StepError(str(e), "INVALID_QUATERNION") from None
        try:
            dt = float(clamp_dt(self.asset, dt_s))
        except ValueError as e:
            raise StepError(str(e), "INVALID_DT") from None
        return rotations, root_translation, root_rotation, dt, dt != float(dt_s)

    def step(self, rotations, root_translation, root_rotation, dt_s):
        rotations, root_translation, root_rotation, dt, clamped = self._validate(
            rotations, root_translation, root_rotation, dt_s)
        # the networks run unless a rate is set and less than its interval has gathered since their last update;
        # then their dt is all that time (docs/inputs.md, "Network update rate"); dt_s as the C API's float
        dt_in = float(np.float32(dt_s))
        run = (self.network_interval <= 0.0 or self.history is None
               or self.network_pending + dt_in >= self.network_interval * (1.0 - 1e-6))
        if not run:
            result = self._skin_held(rotations, root_translation, root_rotation)
            if result is not None:
                self.network_pending += dt_in
                self.last_result = RESULT_OK
                return result
        elif self.network_interval > 0.0:
            wanted = self.network_pending + dt_in      # may exceed 1 s; dt_max ≤ 1 s, so min() changes no result
            dt = float(clamp_dt(self.asset, min(wanted, 1.0)))
            clamped = dt != wanted
        result = None if not run else self._step(rotations, root_translation, root_rotation, dt)
        if result is None:          # non-finite inside the step: reset and recompute from the reset state
            self.reset()
            result = self._step(rotations, root_translation, root_rotation, dt)
            self.last_result = RESULT_NUMERIC_RESET
            if result is None:      # still non-finite: leave the instance reset
                self.reset()
                raise FloatingPointError("step is non-finite even from the reset state")
        else:
            self.last_result = RESULT_CLAMPED if clamped else RESULT_OK
        return result

    def _skin_held(self, rotations, root_translation, root_rotation):
        """A step between network updates: the held blend weights' deformation, skinned with the new pose."""
        f = pose_features(self.parents, self.joints, self.input_joints, rotations[None], root_translation[None],
                          root_rotation[None], self.history["yaw"][0])
        skin_matrices = f["skin_matrices"][0]
        with np.errstate(all="ignore"):
            deformed = blend_shapes(self.shaped_template, self.blend, self.blend_weights)
            positions = skinning(deformed, self.skin_indices, self.skin_weights, skin_matrices)
            vertex_normals = normals(positions, self.faces, self.adjacency_offsets, self.adjacency_faces)
        if not (np.all(np.isfinite(positions)) and np.all(np.isfinite(vertex_normals))):
            return None
        self.skin_matrices = skin_matrices
        return positions, vertex_normals

    def _step(self, rotations, root_translation, root_rotation, dt):
        previous_yaw = 0.0 if self.history is None else self.history["yaw"][0]
        f = pose_features(self.parents, self.joints, self.input_joints, rotations[None], root_translation[None],
                          root_rotation[None], previous_yaw)
        now = {k: v[0] for k, v in f.items()}
        if self.history is None:
            frames, dts = [now, now, now], [dt, dt]
        else:
            frames, dts = [now] + self.history["frames"], [dt, self.history["dt"]]
        stack = lambda key: np.stack([fr[key] for fr in frames])
        with np.errstate(all="ignore"):
            x_c = input_assembly(self.latent, stack("rotations_6d"), stack("positions"), stack("pelvis"),
                                 np.array([fr["yaw"] for fr in frames]), np.array(dts), self.beta,
                                 self.material_normalised)
            y = mlp((x_c - self.x_mean) / self.x_std, self.lp_weights, self.lp_biases, self.lp_activation)
            latent = np.clip(y * self.z_std + self.z_mean, self.z_min, self.z_max)
            blend_weights = mlp(latent, self.dec_weights, self.dec_biases, self.dec_activation)
            deformed = blend_shapes(self.shaped_template, self.blend, blend_weights)
            positions = skinning(deformed, self.skin_indices, self.skin_weights, now["skin_matrices"])
            vertex_normals = normals(positions, self.faces, self.adjacency_offsets, self.adjacency_faces)
        if not all(np.all(np.isfinite(a)) for a in (y, blend_weights, positions, vertex_normals)):
            return None
        self.x_c, self.blend_weights = x_c, blend_weights
        self.latent = latent
        self.skin_matrices = now["skin_matrices"]
        self.history = dict(frames=[now, frames[1]], dt=dt, yaw=[now["yaw"]])
        self.network_pending = 0.0
        return positions, vertex_normals
