"""X_c, the latent predictor's input (docs/inputs.md, "X_c layout"). The one definition shared by training, this
reference and the C runtime (sdk/src/input_assembly.c).

Per pose the runtime keeps a few *pose features* (`pose_features`): the 6D rotations of the input joints plus the pelvis
tilt, the input joints' positions in that frame's heading frame, the pelvis position p_0 and the heading yaw. One step
assembles X_c from the features of frames (t+1, t, t−1), the two dts and the latent (`input_assembly`).
`assemble_inputs` does a whole clip at once with exactly the history rules of the instance (first frame copies itself
into t and t−1), which is what training uses.
"""
import numpy as np

from pleat.asset import input_count
from pleat.rotations import matrix_to_6d, quat_to_matrix, wrap_angle, yaw_matrix, yaw_of
from pleat.reference.forward_kinematics import forward_kinematics
from pleat.reference.shape_blend import shaped_joints

QUATERNION_TOLERANCE = 1e-3


def clamp_beta(asset, beta):
    """β clamped to [beta_min, beta_max] → (β [B] float64, clamped?)."""
    B = np.asarray(asset["shape_blend"]).shape[0]
    given = np.zeros(0) if beta is None else np.asarray(beta, np.float64).reshape(-1)
    if given.shape[0] > B:
        raise ValueError(f"beta: at most {B} values, got {given.shape[0]}")
    beta = np.zeros(B)
    beta[:given.shape[0]] = given          # missing entries are 0, as in plInstanceDef
    if not np.all(np.isfinite(beta)):
        raise ValueError("beta: non-finite")
    lo, hi = np.asarray(asset.get("beta_range", (-4.0, 4.0)), np.float64)
    clamped = np.clip(beta, lo, hi)
    return clamped, bool(np.any(clamped != beta))


def clamp_material(asset, material):
    """Material (m, μ, λ, k) clamped to the asset's ranges → (material [4], normalised [4] in [0, 1], clamped?)."""
    lo = np.asarray(asset["material_min"], np.float64)
    hi = np.asarray(asset["material_max"], np.float64)
    m = np.asarray(asset.get("material_default", (lo + hi) / 2) if material is None else material,
                   np.float64).reshape(-1)
    if m.shape != (4,):
        raise ValueError(f"material: expected 4 values, got {m.shape[0]}")
    if not np.all(np.isfinite(m)):
        raise ValueError("material: non-finite")
    clamped = np.clip(m, lo, hi)
    return clamped, (clamped - lo) / (hi - lo), bool(np.any(clamped != m))


def clamp_dt(asset, dt_s):
    """dt clamped to [dt_min_s, dt_max_s] (after rejecting non-finite and outside (0, 1] s)."""
    dt = np.asarray(dt_s, np.float64)
    if not np.all(np.isfinite(dt)):
        raise ValueError("dt_s: non-finite")
    if np.any(dt <= 0) or np.any(dt > 1.0):
        raise ValueError("dt_s: must be in (0, 1] s")
    lo, hi = np.asarray(asset.get("dt_range_s", (1 / 240, 1 / 15)), np.float64)
    return np.clip(dt, lo, hi)


def normalize_quaternions(q, zero_is_identity=False):
    """Renormalises quaternions within QUATERNION_TOLERANCE of unit length; raises on the rest or non-finite.
    zero_is_identity: an all-zero quaternion means identity (plFrameInput.root_rotation)."""
    q = np.asarray(q, np.float64)
    if not np.all(np.isfinite(q)):
        raise ValueError("quaternion: non-finite")
    if zero_is_identity:
        q = np.where(np.all(q == 0, axis=-1, keepdims=True), np.array([0.0, 0.0, 0.0, 1.0]), q)
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    if np.any(np.abs(n - 1.0) > QUATERNION_TOLERANCE):
        raise ValueError("quaternion: length differs from 1 by more than 1e-3")
    return q / n


def pose_features(joint_parents, joint_locations, input_joints, rotations, root_translation, root_rotation,
                  previous_yaw=0.0):
    """Per-frame features of poses [T] (one clip, in order). rotations [T, J, 4]; root_translation [T, 3];
    root_rotation [T, 4]; previous_yaw: the yaw kept when frame 0's forward axis is vertical.

    Returns dict: rotations_6d [T, 6·Jin + 6], positions [T, 3·Jin], pelvis [T, 3], yaw [T], skin_matrices [T, J, 3, 4].
    """
    rot, pos, skin = forward_kinematics(joint_parents, joint_locations, rotations, root_translation, root_rotation)
    T = rot.shape[0]
    pelvis_rotation = rot[:, 0]                                   # P = Q_root · R_0
    yaw, valid = yaw_of(pelvis_rotation)
    # a vertical forward axis keeps the previous frame's yaw
    last = np.maximum.accumulate(np.where(valid, np.arange(T), -1))
    yaw = np.where(last >= 0, yaw[np.maximum(last, 0)], previous_yaw)
    yaw_inv = np.swapaxes(yaw_matrix(yaw), -1, -2)               # yaw⁻¹ [T, 3, 3]
    ij = np.asarray(input_joints, np.int64)
    local = np.asarray(rotations, np.float64)[:, ij]
    tilt = yaw_inv @ pelvis_rotation
    rot6d = np.concatenate([matrix_to_6d(quat_to_matrix(local)).reshape(T, -1), matrix_to_6d(tilt)], axis=-1)
    relative = pos[:, ij] - pos[:, :1]                            # p_k − p_0
    positions = np.einsum("tij,tkj->tki", yaw_inv, relative).reshape(T, -1)
    return dict(rotations_6d=rot6d, positions=positions, pelvis=pos[:, 0], yaw=yaw, skin_matrices=skin)


def input_assembly(latent, rotations_6d, positions, pelvis, yaw, dt_s, beta, material_normalised):
    """One X_c per leading index. Frame axis (−2 for arrays of vectors, −1 for yaw) holds frames (t+1, t, t−1):
    rotations_6d [..., 3, 6·Jin+6], positions [..., 3, 3·Jin], pelvis [..., 3, 3], yaw [..., 3];
    dt_s [..., 2] = (dt_{t+1}, dt_t) already clamped; latent [..., L] = Z_t raw; beta [B] clamped;
    material_normalised [4]. Returns X_c [..., I]."""
    latent = np.asarray(latent, np.float64)
    yaw = np.asarray(yaw, np.float64)
    pelvis = np.asarray(pelvis, np.float64)
    dt = np.asarray(dt_s, np.float64)
    heading_inv = np.swapaxes(yaw_matrix(yaw[..., 0]), -1, -2)   # yaw_{t+1}⁻¹
    v_t = np.einsum("...ij,...j->...i", heading_inv, pelvis[..., 0, :] - pelvis[..., 1, :]) / dt[..., 0:1]
    v_tm1 = np.einsum("...ij,...j->...i", heading_inv, pelvis[..., 1, :] - pelvis[..., 2, :]) / dt[..., 1:2]
    w_t = wrap_angle(yaw[..., 0] - yaw[..., 1]) / dt[..., 0]
    w_tm1 = wrap_angle(yaw[..., 1] - yaw[..., 2]) / dt[..., 1]
    lead = latent.shape[:-1]
    r6 = np.asarray(rotations_6d, np.float64)
    ps = np.asarray(positions, np.float64)
    return np.concatenate([
        latent,
        v_t, w_t[..., None], v_tm1, w_tm1[..., None],
        r6.reshape(lead + (-1,)),
        ps.reshape(lead + (-1,)),
        np.broadcast_to(np.asarray(beta, np.float64), lead + (np.size(beta),)),
        np.broadcast_to(np.asarray(material_normalised, np.float64), lead + (4,)),
    ], axis=-1)


def assemble_inputs(asset, rotations, root_translation, root_rotation, dt_s, beta=None, material=None,
                    latents=None):
    """X_c for every frame of a clip, as the instance would build it stepping from a reset through the clip.

    asset: an asset/weights dict (read_asset or the weights file); rotations [T, J, 4] local quaternions (x, y, z, w)
    in asset joint order; root_translation [T, 3]; root_rotation [T, 4]; dt_s [T] (dt_s[i] = time from pose i−1 to
    pose i; dt_s[0] only sets the history's dt); beta [B]; material (m, μ, λ, k) (None = material_default);
    latents [T, L]: Z_t for each frame i (the latent *before* step i, i.e. Z_0 = 0 at frame 0), None = zeros — the
    latent block is X_c[:, :L], so rollouts may fill it in later. β, material and dt are clamped as the instance does.
    Returns X_c [T, I] float64."""
    beta, _ = clamp_beta(asset, beta)
    _, material_n, _ = clamp_material(asset, material)
    rotations = normalize_quaternions(rotations)
    root_rotation = normalize_quaternions(root_rotation, zero_is_identity=True)
    T = rotations.shape[0]
    dt = clamp_dt(asset, np.asarray(dt_s, np.float64).reshape(T))
    joints = shaped_joints(asset["joint_template"], asset["joint_shapedirs"], beta)
    f = pose_features(asset["joint_parents"], joints, asset["input_joints"], rotations, root_translation,
                      root_rotation)
    i = np.arange(T)
    hist = np.stack([i, np.maximum(i - 1, 0), np.maximum(i - 2, 0)], axis=1)   # frames t+1, t, t−1
    L = np.asarray(asset["z_mean"]).shape[0]
    latents = np.zeros((T, L)) if latents is None else np.asarray(latents, np.float64).reshape(T, L)
    x = input_assembly(latents, f["rotations_6d"][hist], f["positions"][hist], f["pelvis"][hist], f["yaw"][hist],
                       dt[hist[:, :2]], beta, material_n)
    expected = input_count(L, len(asset["input_joints"]), len(beta))
    assert x.shape == (T, expected), (x.shape, expected)
    return x
