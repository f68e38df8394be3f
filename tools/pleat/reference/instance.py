"""The numpy twin of the C instance (plInstance, sdk/src/instance*.c): pose history, latent, clamps and guards of
docs/inputs.md. `Instance.step` is plInstance_Step (instance_step.c) function for function:

    _validate_step → decide_network_update → _forward_kinematics → _step_from_history
        (_evaluate_networks: input_assembly → input_normalisation → f_LP → latent_guard → f_dec; then _deform:
         blend_shapes → skinning → normals)
    → on a non-finite value _step_from_reset (a first frame with a zero latent; if even that is non-finite, the body
      dressed without the learned deformation) → _commit.

The arithmetic is float64 where C's is float32, so the two agree to the tolerances of test_reference_golden; the
decisions (when the networks run, what is clamped, when the step resets, what is committed) are the same.
"""
from typing import NamedTuple

import numpy as np

from pleat.asset import normal_adjacency
from pleat.reference.blend_shapes import blend_shapes, fold_shape_scales
from pleat.reference.body_contact import BODY_CONTACT_OFFSET_M, body_contact
from pleat.reference.input_assembly import (clamp_beta, clamp_material, input_assembly, normalize_quaternions,
                                            pose_features)
from pleat.reference.input_normalisation import input_normalisation
from pleat.reference.latent_guard import latent_guard
from pleat.reference.mlp import int8_layers, layers, mlp, mlp_int8
from pleat.reference.network_rate import decide_network_update
from pleat.reference.normals import normals
from pleat.reference.shape_blend import shape_blend, shaped_joints
from pleat.reference.skinning import skinning

RESULT_OK, RESULT_CLAMPED, RESULT_NUMERIC_RESET = "ok", "clamped", "numeric_reset"


class StepError(ValueError):
    """A rejected input; `code` is the matching C result name (NON_FINITE_INPUT, INVALID_DT, INVALID_QUATERNION,
    JOINT_COUNT_MISMATCH). The instance is unchanged."""

    def __init__(self, message, code):
        super().__init__(message)
        self.code = code


class StepPose(NamedTuple):
    """Frame t+1 as the jobs read it (instance_step.c plStepPose): checked and normalised."""
    rotations: np.ndarray         # [J, 4] local (x, y, z, w)
    root_translation: np.ndarray  # [3] metres
    root_rotation: np.ndarray     # [4] (x, y, z, w); all zero was taken as identity
    dt_s: float                   # the step's dt as the C API's float, in (0, 1]


class Networks(NamedTuple):
    """What _evaluate_networks computes: X_c, Z_t+1 and the blend weights w."""
    x_c: np.ndarray
    latent: np.ndarray
    blend_weights: np.ndarray


class Outcome(NamedTuple):
    """A step's result before the commit: the latent and weights to commit, and the outputs."""
    networks: object              # Networks, or None where the networks did not run (held weights, or the fallback)
    latent: np.ndarray
    blend_weights: np.ndarray
    positions: np.ndarray
    normals: np.ndarray


class Instance:
    """Instance(asset, beta, material). asset: dict from pleat.asset.read_asset (or a validated weights dict).
    step(rotations [J, 4], root_translation [3], root_rotation [4], dt_s) → (positions [N, 3], normals [N, 3]).
    `last_result` is "ok", "clamped" or "numeric_reset" after each call that changes state."""

    def __init__(self, asset, beta=None, material=None, network_rate_hz=0.0, body_contact=True,
                 body_contact_offset_m=BODY_CONTACT_OFFSET_M):
        self.asset = asset
        # plInstanceDef.body_contact / body_contact_offset_m: on where the asset carries body points; "fast" (or 2,
        # PLEAT_BODY_CONTACT_FAST): each vertex's own point with its turned rest normal, where the asset's rows
        # 0..N-1 are the vertices' own (else the full contact, as the runtime does)
        self.body_contact = bool(body_contact) and asset.get("body_anchor") is not None
        self.body_contact_offset_m = float(np.float32(body_contact_offset_m))
        if self.body_contact:
            self.anchor_normals = np.asarray(asset["body_anchor_normal"], np.float64)
            self.anchor_skin_indices = np.asarray(asset["body_anchor_skin_indices"], np.int64)
            self.anchor_skin_weights = np.asarray(asset["body_anchor_skin_weights"], np.float64)
            self.anchor_candidates = asset.get("body_anchor_candidates")     # None: one point per vertex (1.1)
            self.anchor_ring = asset.get("body_anchor_ring")                 # None: rotated rest normals
            N, table = len(asset["template"]), self.anchor_candidates
            fast_ready = len(self.anchor_normals) >= N and (
                table is None or bool(np.all((table[:, 0] == np.arange(N)) | (table[:, 0] == 0xFFFF))))
            self.body_contact_fast = fast_ready and (body_contact in (2, "fast") or (
                table is None and self.anchor_ring is None))
        self.parents = np.asarray(asset["joint_parents"], np.int64)
        self.input_joints = np.asarray(asset["input_joints"], np.int64)
        self.faces = np.asarray(asset["faces"], np.int64)
        self.skin_indices = np.asarray(asset["skin_indices"], np.int64)
        self.skin_weights = np.asarray(asset["skin_weights"], np.float64)
        # int8 blend shapes: q, with each shape's scale folded into its weight per step (fold_shape_scales)
        self.shape_scales = asset.get("blend_shape_scales")
        self.blend = np.asarray(asset["blend_shapes_int8"] if self.shape_scales is not None else asset["blend_shapes"],
                                np.float64)
        self.adjacency_offsets, self.adjacency_faces = normal_adjacency(self.faces, self.blend.shape[1])
        # int8 networks (asset 1.3) run the runtime's integer arithmetic (mlp_int8); float ones in float64
        self.lp_int8, self.dec_int8 = int8_layers(asset, "lp"), int8_layers(asset, "dec")
        self.lp_weights, self.lp_biases = layers(asset, "lp") if self.lp_int8 is None else (None, None)
        self.dec_weights, self.dec_biases = layers(asset, "dec") if self.dec_int8 is None else (None, None)
        self.lp_activation = str(asset["lp_activation"])
        self.dec_activation = str(asset["dec_activation"])
        f64 = lambda k: np.asarray(asset[k], np.float64)
        self.x_mean, self.x_std = f64("x_mean"), f64("x_std")
        self.z_mean, self.z_std, self.z_min, self.z_max = f64("z_mean"), f64("z_std"), f64("z_min"), f64("z_max")
        self.dt_min_s, self.dt_max_s = (float(v) for v in np.asarray(asset.get("dt_range_s", (1 / 240, 1 / 15)),
                                                                         np.float32))
        self.joint_count = len(self.parents)
        self.latent_count = len(self.z_mean)
        self.last_result = RESULT_OK
        self.blend_weights = np.zeros(self.blend.shape[0])     # as plCreateInstance: zero until the first step
        self.skin_matrices = np.broadcast_to(np.eye(3, 4), (self.joint_count, 3, 4)).copy()   # the rest pose
        self.x_c = None
        self.set_shape(beta)
        self.set_material(material)
        self.set_network_rate(network_rate_hz)
        self.reset()

    def set_shape(self, beta):
        """Clamps β and recomputes the shaped template T + G_S(β) and the rest joints J(β). Returns True if β was
        clamped."""
        self.beta, clamped = clamp_beta(self.asset, beta)
        self.shaped_template = shape_blend(self.asset["template"], self.asset["shape_blend"], self.beta)
        self.joints = shaped_joints(self.asset["joint_template"], self.asset["joint_shapedirs"], self.beta)
        if self.body_contact:
            self.shaped_anchors = shape_blend(self.asset["body_anchor"], self.asset["body_anchor_shape"], self.beta)
        return clamped

    def set_material(self, material):
        """Clamps the material (m, μ, λ, k). Returns True if it was clamped."""
        self.material, self.material_normalised, clamped = clamp_material(self.asset, material)
        return clamped

    def set_network_rate(self, network_rate_hz):
        """Run the networks at most this often (Hz; 0 = every step), as plInstanceDef.network_rate_hz (a float)."""
        rate = float(network_rate_hz)
        if not (np.isfinite(rate) and rate >= 0.0):
            raise ValueError("network_rate_hz: must be finite and >= 0")
        rate = float(np.float32(rate))
        self.network_interval_s = 1.0 / rate if rate > 0.0 else 0.0

    def reset(self):
        """plInstance_Reset: the next step is a first frame with a zero latent."""
        self.latent = np.zeros(self.latent_count)
        self.history = None            # frames t and t−1 (of the networks: the frames at their last two updates)
        self.network_pending_s = 0.0   # time since the last network update

    def step(self, rotations, root_translation, root_rotation, dt_s):
        pose = self._validate_step(rotations, root_translation, root_rotation, dt_s)
        update = decide_network_update(self.network_interval_s, self.network_pending_s, pose.dt_s,
                                       self.history is None, self.dt_min_s, self.dt_max_s)
        # nothing has changed so far, and nothing changes until the commit
        frame = self._forward_kinematics(pose, update.dt_s, 0.0 if self.history is None else self.history[0]["yaw"])
        outcome = self._step_from_history(frame, update)
        reset = outcome is None
        if reset:
            frame, outcome = self._step_from_reset(pose, update.dt_s)
        self._commit(frame, outcome, update.run or reset, reset, pose.dt_s)
        self.last_result = (RESULT_NUMERIC_RESET if reset else RESULT_CLAMPED if update.dt_clamped else RESULT_OK)
        return outcome.positions, outcome.normals

    def _validate_step(self, rotations, root_translation, root_rotation, dt_s):
        """Joint count, then non-finite values, then quaternion lengths, then the dt range (as plValidateStep)."""
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
        dt = float(np.float32(dt_s))          # plFrameInput.dt_s is a float
        if not dt > 0.0 or dt > 1.0:
            raise StepError("dt_s: must be in (0, 1] s", "INVALID_DT")
        return StepPose(rotations, root_translation, root_rotation, dt)

    def _forward_kinematics(self, pose, dt_s, previous_yaw):
        """Frame t+1: pose features, skinning matrices and the dt from the frame before (plRunForwardKinematics)."""
        f = pose_features(self.parents, self.joints, self.input_joints, pose.rotations[None],
                          pose.root_translation[None], pose.root_rotation[None], previous_yaw)
        frame = {k: v[0] for k, v in f.items()}
        frame["dt_s"] = dt_s
        return frame

    def _evaluate_networks(self, frame, history, latent):
        """Z_t+1 and w from frame t+1, the history [t, t−1] (None = a first frame: t+1 stands in for both) and Z_t.
        None if f_LP's output, the weights or the skinning matrices are not all finite."""
        frames = [frame] + (history if history is not None else [frame, frame])
        stack = lambda key: np.stack([fr[key] for fr in frames])
        with np.errstate(all="ignore"):
            x_c = input_assembly(latent, stack("rotations_6d"), stack("positions"), stack("pelvis"),
                                 np.array([fr["yaw"] for fr in frames]),
                                 np.array([frames[0]["dt_s"], frames[1]["dt_s"]]), self.beta,
                                 self.material_normalised)
            x = input_normalisation(x_c, self.x_mean, self.x_std)
            y = (mlp(x, self.lp_weights, self.lp_biases, self.lp_activation) if self.lp_int8 is None
                 else mlp_int8(x, self.lp_int8, self.lp_activation).astype(np.float64))
            if not np.all(np.isfinite(y)):
                return None                  # before the guard: its clamp would turn an overflow into a bound
            next_latent = latent_guard(y, self.z_mean, self.z_std, self.z_min, self.z_max)
            blend_weights = (mlp(next_latent, self.dec_weights, self.dec_biases, self.dec_activation)
                             if self.dec_int8 is None
                             else mlp_int8(next_latent, self.dec_int8, self.dec_activation).astype(np.float64))
        if not (np.all(np.isfinite(blend_weights)) and np.all(np.isfinite(frame["skin_matrices"]))):
            return None
        return Networks(x_c, next_latent, blend_weights)

    def _deform(self, blend_weights, skin_matrices):
        """T_def → x' → n (plDeform). Returns (positions, normals, finite)."""
        with np.errstate(all="ignore"):
            weights = blend_weights if self.shape_scales is None else fold_shape_scales(blend_weights,
                                                                                         self.shape_scales)
            deformed = blend_shapes(self.shaped_template, self.blend, weights)
            positions = skinning(deformed, self.skin_indices, self.skin_weights, skin_matrices)
            if self.body_contact and self.body_contact_fast:               # rows 0..N-1: one point per vertex
                N = len(positions)
                positions = body_contact(positions, self.shaped_anchors[:N], self.anchor_normals[:N],
                                         self.anchor_skin_indices[:N], self.anchor_skin_weights[:N], skin_matrices,
                                         self.body_contact_offset_m)
            elif self.body_contact:
                positions = body_contact(positions, self.shaped_anchors, self.anchor_normals, self.anchor_skin_indices,
                                         self.anchor_skin_weights, skin_matrices, self.body_contact_offset_m,
                                         self.anchor_candidates, self.anchor_ring, reach=True)
            vertex_normals = normals(positions, self.faces, self.adjacency_offsets, self.adjacency_faces)
        return positions, vertex_normals, bool(np.all(np.isfinite(positions)) and np.all(np.isfinite(vertex_normals)))

    def _step_from_history(self, frame, update):
        """The step as asked: the networks from the history when the rate decision runs them, else the held weights
        skinned with the new pose. None if a value is not finite."""
        if not update.run:
            positions, vertex_normals, finite = self._deform(self.blend_weights, frame["skin_matrices"])
            return Outcome(None, self.latent, self.blend_weights, positions, vertex_normals) if finite else None
        networks = self._evaluate_networks(frame, self.history, self.latent)
        if networks is None:
            return None
        positions, vertex_normals, finite = self._deform(networks.blend_weights, frame["skin_matrices"])
        return Outcome(networks, networks.latent, networks.blend_weights, positions, vertex_normals) if finite else None

    def _step_from_reset(self, pose, dt_s):
        """The numeric reset: frame t+1 as a first frame (previous yaw 0) with a zero latent; if even that is not
        finite, the body dressed without the learned deformation (zero latent and weights), committed as it is."""
        frame = self._forward_kinematics(pose, dt_s, 0.0)
        zero_latent = np.zeros(self.latent_count)
        networks = self._evaluate_networks(frame, None, zero_latent)
        if networks is not None:
            positions, vertex_normals, finite = self._deform(networks.blend_weights, frame["skin_matrices"])
            if finite:
                return frame, Outcome(networks, networks.latent, networks.blend_weights, positions, vertex_normals)
        zero_weights = np.zeros(self.blend.shape[0])
        positions, vertex_normals, _ = self._deform(zero_weights, frame["skin_matrices"])
        return frame, Outcome(None, zero_latent, zero_weights, positions, vertex_normals)

    def _commit(self, frame, outcome, networks_ran, reset, dt_s):
        """After a network update: t−1 ← t (or t+1 on a first frame or after a reset), t ← t+1, Z_t ← Z_t+1,
        w ← w_next. Between updates only the pose-dependent outputs change, and the time since the update grows."""
        if networks_ran:
            previous = self.history[0] if self.history is not None and not reset else frame
            self.history = [frame, previous]
            self.network_pending_s = 0.0
            self.latent = outcome.latent
            self.blend_weights = outcome.blend_weights
            if outcome.networks is not None:
                self.x_c = outcome.networks.x_c
        else:
            self.network_pending_s += dt_s
        self.skin_matrices = frame["skin_matrices"]
