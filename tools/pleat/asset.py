"""Pleat asset format v1: writer and reader (docs/asset-format.md). No PyTorch.

    data = write_asset("shirt.pleat", weights)        # weights: the dict of docs/asset-format.md "The weights file"
    weights = read_asset(data)                        # same keys back; validates structure, checksum and meaning

`write_asset` validates everything it writes (shapes, finiteness, index ranges, layer chains, skin-weight sums) and
raises `AssetError` with a message naming the key. `read_asset` raises `AssetError` whose `code` is the name of the C
runtime's result for the same fault (`BAD_MAGIC`, `TRUNCATED`, `CHECKSUM_MISMATCH`, `LEGACY_VERSION`,
`UNSUPPORTED_VERSION`, `MALFORMED_ASSET`, `INVALID_ASSET_DATA`).
"""
from __future__ import annotations

import io
import json
import os
import struct
import zlib
from pathlib import Path

import numpy as np

MAGIC = b"PLEATAST"
VERSION_MAJOR = 1
VERSION_MINOR = 4   # 1.1 adds the optional body-contact sections (BANC …), 1.2 their candidates (BACA), 1.3 int8
                    # networks, 1.4 int8 blend shapes
HEADER_SIZE = 128
SECTION_ENTRY_SIZE = 48
CONF_SIZE = 256
ALIGN = 64
CHECKSUM_OFFSET = 40
FLAG_FP16 = 1
FLAG_INT8 = 2       # 1.3: every LP and decoder layer is int8 (LPWi i8, LPSi, LPAi; docs/asset-format.md)
FLAG_INT8_RANGED_INPUTS = 4   # 1.3, with FLAG_INT8 and ReLU networks: each layer's input quantised to the range its
                              # values have (pleat.reference.mlp.int8_input_bounds): 'int8_ranged_inputs' in a dict
FLAG_INT8_BLEND_SHAPES = 8    # 1.4: BLND is int8 in [-127, 127] with a scale per shape (BLSC): 'blend_shapes_int8' and
                              # 'blend_shape_scales' in a dict (pleat.quantise.quantise_blend_shapes)
KNOWN_FLAGS = FLAG_FP16 | FLAG_INT8 | FLAG_INT8_RANGED_INPUTS | FLAG_INT8_BLEND_SHAPES
MAX_INT8_COLUMNS = 4096   # PLEAT_MAX_INT8_COLUMNS: an int8 layer's inputs (the kernels quantise them on their stack)

DTYPE_F32, DTYPE_F16, DTYPE_U32, DTYPE_U16, DTYPE_I32, DTYPE_U8, DTYPE_I8 = 1, 2, 3, 4, 5, 6, 7
_NUMPY_OF_DTYPE = {DTYPE_F32: np.dtype("<f4"), DTYPE_F16: np.dtype("<f2"), DTYPE_U32: np.dtype("<u4"),
                   DTYPE_U16: np.dtype("<u2"), DTYPE_I32: np.dtype("<i4"), DTYPE_U8: np.dtype("u1"),
                   DTYPE_I8: np.dtype("i1")}

ACTIVATIONS = {"relu": 1, "silu": 2}
ACTIVATION_NAMES = {v: k for k, v in ACTIVATIONS.items()}

MAX_JOINTS = 64
MAX_BETAS = 16
MAX_INFLUENCES = 8
MAX_LAYERS = 10
MAX_NAME_BYTES = 64
JOINT_NAME_BYTES = 32
SKIN_WEIGHT_SUM_TOLERANCE = 1e-3

DEFAULT_DT_RANGE_S = (1.0 / 240.0, 1.0 / 15.0)
DEFAULT_BETA_RANGE = (-4.0, 4.0)
DEFAULT_TRAIN_FPS = 30.0

# CONF field offsets (docs/asset-format.md, "CONF").
_CONF_U32_FIELDS = ["vertex_count", "face_count", "joint_count", "input_joint_count", "influence_count", "beta_count",
                    "latent_count", "blend_count", "lp_layer_count", "dec_layer_count", "lp_activation",
                    "dec_activation", "input_count"]


class AssetError(ValueError):
    """An asset that cannot be written or read. `code` names the C runtime's matching plResult (without prefix)."""

    def __init__(self, message, code="INVALID_ASSET_DATA"):
        super().__init__(message)
        self.code = code


def input_layout(latent_count, input_joint_count, beta_count):
    """The blocks of X_c in order (docs/inputs.md "X_c layout"), as slices: latent Z_t [L]; root_velocities [8] (v and
    ω of t+1 and t); rotations [3·(6·Jin + 6)] (6D of the input joints and the pelvis tilt, frames t+1, t, t−1);
    positions [9·Jin] (heading-frame joint positions, 3 frames); beta [B]; material [4]. The one Python definition
    (pleat.reference.input_assembly builds X_c in this order); the C twin is plInputCountFormula in
    sdk/src/input_assembly.c."""
    sizes = (("latent", latent_count), ("root_velocities", 8), ("rotations", 3 * (6 * input_joint_count + 6)),
             ("positions", 9 * input_joint_count), ("beta", beta_count), ("material", 4))
    layout, start = {}, 0
    for name, size in sizes:
        layout[name] = slice(start, start + size)
        start += size
    return layout


def input_count(latent_count, input_joint_count, beta_count):
    """I of docs/inputs.md: L + 8 + 3·(6·Jin + 6) + 9·Jin + B + 4, the end of input_layout."""
    return input_layout(latent_count, input_joint_count, beta_count)["material"].stop


def normal_adjacency(faces, vertex_count):
    """CSR list of the faces around each vertex: (offsets [N+1] u32, face indices [3F] u32, ascending per vertex)."""
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    vertex_of_slot = faces.reshape(-1)
    face_of_slot = np.repeat(np.arange(len(faces), dtype=np.int64), 3)
    order = np.lexsort((face_of_slot, vertex_of_slot))  # by vertex, then by face
    counts = np.bincount(vertex_of_slot, minlength=vertex_count)
    offsets = np.zeros(vertex_count + 1, dtype=np.uint32)
    np.cumsum(counts, out=offsets[1:])
    return offsets, face_of_slot[order].astype(np.uint32)


def _layer_count(weights, prefix):
    count = 0
    while f"{prefix}.{count}.weight" in weights:
        count += 1
    return count


def _text(value, key):
    if isinstance(value, bytes):
        return value.decode("utf-8")
    if isinstance(value, np.ndarray):
        if value.ndim != 0:
            raise AssetError(f"{key}: expected a string, got an array of shape {value.shape}")
        value = value.item()
        if isinstance(value, bytes):
            return value.decode("utf-8")
    if not isinstance(value, str):
        raise AssetError(f"{key}: expected a string, got {type(value).__name__}")
    return value


def _floats(weights, key, shape, keep_fp16=False):
    if key not in weights:
        raise AssetError(f"missing key {key!r}")
    a = np.asarray(weights[key])
    if a.dtype.kind not in "fiu":
        raise AssetError(f"{key}: expected numbers, got dtype {a.dtype}")
    if tuple(a.shape) != tuple(shape):
        raise AssetError(f"{key}: shape {tuple(a.shape)}, expected {tuple(shape)}")
    if not keep_fp16 or a.dtype != np.float16:
        a = a.astype(np.float32)
    if not np.all(np.isfinite(a)):
        raise AssetError(f"{key}: contains non-finite values")
    return a


def _ints(weights, key, shape, lo, hi):
    """Integer array with every value in [lo, hi)."""
    if key not in weights:
        raise AssetError(f"missing key {key!r}")
    a = np.asarray(weights[key])
    if a.dtype.kind == "f":
        if not np.all(np.isfinite(a)) or np.any(a != np.round(a)):
            raise AssetError(f"{key}: expected integers")
    elif a.dtype.kind not in "iu":
        raise AssetError(f"{key}: expected integers, got dtype {a.dtype}")
    if tuple(a.shape) != tuple(shape):
        raise AssetError(f"{key}: shape {tuple(a.shape)}, expected {tuple(shape)}")
    a = a.astype(np.int64)
    if a.size and (a.min() < lo or a.max() >= hi):
        raise AssetError(f"{key}: values must lie in [{lo}, {hi}), got [{a.min()}, {a.max()}]")
    return a


def _range(weights, key, default, lo=-np.inf, hi=np.inf):
    value = weights.get(key, default)
    a = np.asarray(value, dtype=np.float64).reshape(-1)
    if a.shape != (2,) or not np.all(np.isfinite(a)) or not (lo <= a[0] <= a[1] <= hi):
        raise AssetError(f"{key}: expected [min, max] with {lo} <= min <= max <= {hi}, got {value!r}")
    return a


def is_int8(weights):
    """True if the weights dict holds int8 networks (pleat.quantise: int8 'lp.0.weight' with its scales)."""
    return np.asarray(weights.get("lp.0.weight", np.zeros(0, np.float32))).dtype == np.int8


def has_int8_blend_shapes(weights):
    """True if the weights dict holds int8 blend shapes (pleat.quantise.quantise_blend_shapes)."""
    return "blend_shape_scales" in weights


def blend_shape_values(q, scales):
    """int8 blend shapes [D, N, 3] and their scales [D] as the runtime's kernels read them: float32((float)q · scale),
    one rounding (plShapeElement)."""
    return (np.asarray(q, np.float32) * np.asarray(scales, np.float32)[:, None, None]).astype(np.float32)


def _int8_layer(weights, w, key, m):
    """An int8 layer (1.3): KEY.weight int8 [out, in] in -127..127, KEY.weight_scale [out] and KEY.input_scale [1]
    positive, finite, the input scale's float32 reciprocal finite too (pleat.reference.mlp.mlp_int8)."""
    if m.dtype != np.int8:
        raise AssetError(f"{key}.weight: dtype {m.dtype}; an int8 network has int8 weights in every layer")
    if m.size and int(m.min()) < -127:
        raise AssetError(f"{key}.weight: -128 (int8 weights are symmetric, -127..127)")
    if m.shape[1] > MAX_INT8_COLUMNS:
        raise AssetError(f"{key}.weight: {m.shape[1]} inputs, an int8 layer has at most {MAX_INT8_COLUMNS}")
    w[f"{key}.weight"] = np.ascontiguousarray(m)
    for name, shape in (("weight_scale", (m.shape[0],)), ("input_scale", (1,))):
        k = f"{key}.{name}"
        if weights.get(k) is None:
            raise AssetError(f"missing key '{k}' (int8 layer)")
        v = _floats({k: np.asarray(weights[k]).reshape(shape)}, k, shape)
        if not np.all(v > 0):
            raise AssetError(f"{k}: must be positive")
        w[k] = v
    with np.errstate(over="ignore", divide="ignore"):
        if not np.isfinite(np.float32(1.0) / w[f"{key}.input_scale"][0]):
            raise AssetError(f"{key}.input_scale: its reciprocal is not finite")


def validate_weights(weights, fp16=False):
    """Checks a weights dict and returns it canonicalised: float arrays as float32 (weight matrices and blend_shapes
    as float16 when fp16), integer arrays as int64, strings as str, plus the derived counts under 'counts'. An int8
    network (pleat.quantise) keeps its int8 weights and their scales; fp16 then applies to blend_shapes only."""
    int8 = is_int8(weights)
    w = {}
    names = weights.get("joint_names")
    if names is None:
        raise AssetError("missing key 'joint_names'")
    names = [_text(n, "joint_names") if not isinstance(n, str) else n for n in np.asarray(names).reshape(-1).tolist()]
    J = len(names)
    if not 1 <= J <= MAX_JOINTS:
        raise AssetError(f"joint_names: {J} joints, expected 1..{MAX_JOINTS}")
    for n in names:
        if not n or len(n.encode("utf-8")) >= JOINT_NAME_BYTES or "\0" in n:
            raise AssetError(f"joint_names: {n!r} must be 1..{JOINT_NAME_BYTES - 1} utf-8 bytes without NUL")
    if len(set(names)) != J:
        raise AssetError("joint_names: names must be unique")
    w["joint_names"] = names

    name = _text(weights.get("garment_name", ""), "garment_name")
    if not name or len(name.encode("utf-8")) > MAX_NAME_BYTES or "\0" in name:
        raise AssetError(f"garment_name: {name!r} must be 1..{MAX_NAME_BYTES} utf-8 bytes without NUL")
    w["garment_name"] = name
    if weights.get("metadata_json") is not None:
        meta = _text(weights["metadata_json"], "metadata_json")
        try:
            json.loads(meta)
        except ValueError as e:
            raise AssetError(f"metadata_json: not valid JSON ({e})") from None
        w["metadata_json"] = meta

    parents = _ints(weights, "joint_parents", (J,), -1, J)
    if parents[0] != -1 or np.any(parents[1:] < 0) or np.any(parents[1:] >= np.arange(1, J)):
        raise AssetError("joint_parents: need parent[0] = -1 and 0 <= parent[k] < k for k > 0")
    w["joint_parents"] = parents

    template = np.asarray(weights.get("template", np.zeros((0, 0))))
    if template.ndim != 2 or template.shape[1] != 3 or template.shape[0] < 3:
        raise AssetError(f"template: expected [N, 3] with N >= 3, got {template.shape}")
    N = template.shape[0]
    shape_blend = np.asarray(weights.get("shape_blend", np.zeros((0,))))
    if shape_blend.ndim != 3:
        raise AssetError(f"shape_blend: expected [B, N, 3], got {shape_blend.shape}")
    B = shape_blend.shape[0]
    if B > MAX_BETAS:
        raise AssetError(f"shape_blend: {B} shape components, at most {MAX_BETAS}")
    w["template"] = _floats(weights, "template", (N, 3))
    w["shape_blend"] = _floats(weights, "shape_blend", (B, N, 3))
    w["joint_template"] = _floats(weights, "joint_template", (J, 3))
    w["joint_shapedirs"] = _floats(weights, "joint_shapedirs", (B, J, 3))

    faces = np.asarray(weights.get("faces", np.zeros((0,))))
    if faces.ndim != 2 or faces.shape[1] != 3 or faces.shape[0] < 1:
        raise AssetError(f"faces: expected [F, 3] with F >= 1, got {faces.shape}")
    w["faces"] = faces = _ints(weights, "faces", faces.shape, 0, N)
    if np.any((faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2])):
        raise AssetError("faces: a triangle repeats a vertex")
    F = faces.shape[0]

    input_joints = np.asarray(weights.get("input_joints", np.zeros((0,))))
    Jin = input_joints.reshape(-1).shape[0]
    w["input_joints"] = ij = _ints(weights, "input_joints", (Jin,), 1, J)
    if Jin < 1 or np.any(np.diff(ij) <= 0):
        raise AssetError("input_joints: need at least one, strictly ascending, none is joint 0")

    skin_indices = np.asarray(weights.get("skin_indices", np.zeros((0,))))
    if skin_indices.ndim != 2 or skin_indices.shape[0] != N or not 1 <= skin_indices.shape[1] <= MAX_INFLUENCES:
        raise AssetError(f"skin_indices: expected [N={N}, K] with K in 1..{MAX_INFLUENCES}, got {skin_indices.shape}")
    K = skin_indices.shape[1]
    w["skin_indices"] = _ints(weights, "skin_indices", (N, K), 0, J)
    w["skin_weights"] = _floats(weights, "skin_weights", (N, K))
    _skin_weights(w, "skin_weights", K)

    z_mean = np.asarray(weights.get("z_mean", np.zeros((0,))))
    L = z_mean.reshape(-1).shape[0]
    if L < 1:
        raise AssetError("z_mean: expected [L] with L >= 1")
    for key in ("z_mean", "z_std", "z_min", "z_max"):
        w[key] = _floats(weights, key, (L,))
    if np.any(w["z_std"] <= 0):
        raise AssetError("z_std: must be positive")
    if np.any(w["z_min"] > w["z_max"]):
        raise AssetError("z_min/z_max: z_min > z_max")
    I = input_count(L, Jin, B)
    w["x_mean"] = _floats(weights, "x_mean", (I,))
    w["x_std"] = _floats(weights, "x_std", (I,))
    if np.any(w["x_std"] <= 0):
        raise AssetError("x_std: must be positive")

    blend = np.asarray(weights.get("blend_shapes", np.zeros((0,))))
    if blend.ndim != 3 or blend.shape[1:] != (N, 3) or blend.shape[0] < 1:
        raise AssetError(f"blend_shapes: expected [D, N={N}, 3], got {blend.shape}")
    D = blend.shape[0]
    w["blend_shapes"] = _floats(weights, "blend_shapes", blend.shape, keep_fp16=True)
    if has_int8_blend_shapes(weights):
        q = np.asarray(weights.get("blend_shapes_int8", np.zeros(0)))
        scales = np.asarray(weights["blend_shape_scales"])
        if q.dtype != np.int8 or q.shape != blend.shape or int(q.min(initial=0)) < -127:
            raise AssetError(f"blend_shapes_int8: expected int8 [D, N={N}, 3] in -127..127 beside blend_shapes "
                             f"{blend.shape}, got {q.dtype} {q.shape}")
        if scales.shape != (D,) or not np.all(np.isfinite(scales)) or np.any(scales <= 0):
            raise AssetError(f"blend_shape_scales: expected [{D}] finite and positive, got {scales.shape}")
        values = blend_shape_values(q, scales)                 # what the runtime reads: the file has no other copy
        if not np.array_equal(np.asarray(blend, np.float32), values):
            raise AssetError("blend_shapes: not the values of blend_shapes_int8 and blend_shape_scales (changed "
                             "after quantising?): quantise them again (pleat.quantise.quantise_blend_shapes) or "
                             "drop the two int8 keys")
        w["blend_shapes_int8"] = q
        w["blend_shape_scales"] = scales.astype(np.float32)
        w["blend_shapes"] = values
    elif fp16:
        w["blend_shapes"] = _to_fp16(w["blend_shapes"], "blend_shapes")

    for prefix, first_in, last_out in (("lp", I, L), ("dec", L, D)):
        count = _layer_count(weights, prefix)
        if not 1 <= count <= MAX_LAYERS:
            raise AssetError(f"{prefix}: {count} layers ('{prefix}.0.weight' ...), expected 1..{MAX_LAYERS}")
        fan_in = first_in
        for i in range(count):
            wk, bk = f"{prefix}.{i}.weight", f"{prefix}.{i}.bias"
            m = np.asarray(weights[wk])
            if m.ndim != 2 or m.shape[1] != fan_in:
                raise AssetError(f"{wk}: shape {m.shape}, expected [out, {fan_in}] (layer chain)")
            if int8:
                _int8_layer(weights, w, f"{prefix}.{i}", m)
            else:
                w[wk] = _floats(weights, wk, m.shape, keep_fp16=True)
                if fp16:
                    w[wk] = _to_fp16(w[wk], wk)
            w[bk] = _floats(weights, bk, (m.shape[0],))
            fan_in = m.shape[0]
        if fan_in != last_out:
            raise AssetError(f"{prefix}.{count - 1}.weight: last layer has {fan_in} outputs, expected {last_out}")
        act = _text(weights.get(f"{prefix}_activation", "relu"), f"{prefix}_activation").lower()
        if act not in ACTIVATIONS:
            raise AssetError(f"{prefix}_activation: {act!r}, expected one of {sorted(ACTIVATIONS)}")
        w[f"{prefix}_activation"] = act
    if int8 and weights.get("int8_ranged_inputs", False):     # (float networks have no int8 inputs to describe)
        if (w["lp_activation"], w["dec_activation"]) != ("relu", "relu"):
            raise AssetError("int8_ranged_inputs: hidden inputs are quantised as never negative, which needs ReLU "
                             f"networks, not {w['lp_activation']}/{w['dec_activation']}")
        w["int8_ranged_inputs"] = True
    extra = [k for k in weights if (k.startswith("lp.") or k.startswith("dec.")) and k not in w]
    if extra:
        raise AssetError(f"layer keys outside the chain: {sorted(extra)}")

    w["dt_range_s"] = _range(weights, "dt_range_s", DEFAULT_DT_RANGE_S, lo=1e-6, hi=1.0).astype(np.float32)
    w["beta_range"] = _range(weights, "beta_range", DEFAULT_BETA_RANGE).astype(np.float32)
    mmin = _floats(weights, "material_min", (4,))
    mmax = _floats(weights, "material_max", (4,))
    if np.any(mmax <= mmin):
        raise AssetError("material_max must exceed material_min in every component")
    mdef = _floats({"material_default": weights.get("material_default", (mmin.astype(np.float64) + mmax) / 2)},
                   "material_default", (4,))
    if np.any(mdef < mmin) or np.any(mdef > mmax):
        raise AssetError("material_default must lie in [material_min, material_max]")
    w["material_min"], w["material_max"], w["material_default"] = mmin, mmax, mdef
    fps = np.asarray(weights.get("train_fps", DEFAULT_TRAIN_FPS), dtype=np.float64)
    if fps.size != 1 or not np.isfinite(fps) or fps.reshape(()) <= 0:
        raise AssetError(f"train_fps: expected a positive scalar, got {weights.get('train_fps')!r}")
    w["train_fps"] = np.float32(fps.reshape(()))

    if weights.get("pinned") is not None:
        p = np.asarray(weights["pinned"]).reshape(-1)
        w["pinned"] = _ints({"pinned": p}, "pinned", p.shape, 0, N)
    _validate_body_contact(weights, w, N, B, J)
    w["counts"] = dict(vertex_count=N, face_count=F, joint_count=J, input_joint_count=Jin, influence_count=K,
                       beta_count=B, latent_count=L, blend_count=D, lp_layer_count=_layer_count(weights, "lp"),
                       dec_layer_count=_layer_count(weights, "dec"), input_count=I)
    return w


BODY_CONTACT_KEYS = ("body_anchor", "body_anchor_shape", "body_anchor_normal", "body_anchor_skin_indices",
                     "body_anchor_skin_weights")
BODY_NORMAL_TOLERANCE = 1e-3
BODY_CONTACT_SECTIONS = ("BANC", "BASH", "BANN", "BASI", "BASW")
# Asset 1.2: each garment vertex's candidate body points (BACA, [N, C] uint16, NO_CANDIDATE = an empty slot)
BODY_CONTACT_CANDIDATES_KEY = "body_anchor_candidates"
MAX_CONTACT_CANDIDATES = 16      # PLEAT_MAX_CONTACT_CANDIDATES
NO_CANDIDATE = 0xFFFF
# Asset 1.2: each body point's ring (BARG, [P, R] uint16: the m >= 3 points around it, counter-clockwise seen from
# outside, then NO_CANDIDATE; all NO_CANDIDATE = no ring), from which the runtime computes the posed body's normal there
BODY_CONTACT_RING_KEY = "body_anchor_ring"
MAX_POINT_RING = 8               # PLEAT_MAX_POINT_RING


def _skin_weights(w, key, K):
    """The skin weights under key, [N, K]: non-negative, each row summing to 1 ± SKIN_WEIGHT_SUM_TOLERANCE."""
    sw = w[key]
    if np.any(sw < 0):
        raise AssetError(f"{key}: negative weight")
    sums = sw.astype(np.float64).sum(axis=1)
    if np.any(np.abs(sums - 1.0) > SKIN_WEIGHT_SUM_TOLERANCE):
        bad = int(np.argmax(np.abs(sums - 1.0)))
        raise AssetError(f"{key}: vertex {bad} sums to {sums[bad]:.6f}, expected 1 ± {SKIN_WEIGHT_SUM_TOLERANCE}")
    return sw


def _validate_body_contact(weights, w, N, B, J):
    """The optional body-contact block (docs/asset-format.md "Body contact"): the five point keys, all or none, and
    (asset 1.2) the candidates. Without candidates there is one point per vertex (P = N, asset 1.1)."""
    present = [k for k in BODY_CONTACT_KEYS if weights.get(k) is not None]
    candidates = weights.get(BODY_CONTACT_CANDIDATES_KEY)
    ring = weights.get(BODY_CONTACT_RING_KEY)
    if not present:
        if candidates is not None or ring is not None:
            raise AssetError(f"{BODY_CONTACT_CANDIDATES_KEY} or {BODY_CONTACT_RING_KEY} without the body points "
                             f"({list(BODY_CONTACT_KEYS)})")
        return
    if len(present) != len(BODY_CONTACT_KEYS):
        raise AssetError(f"body contact: need all of {list(BODY_CONTACT_KEYS)} or none, got {present}")
    points = np.asarray(weights["body_anchor"])
    P = points.shape[0] if points.ndim == 2 else -1
    if candidates is None and P != N:
        raise AssetError(f"body_anchor: {P} points without {BODY_CONTACT_CANDIDATES_KEY} (one per vertex: N = {N})")
    if not 1 <= P < NO_CANDIDATE:
        raise AssetError(f"body_anchor: expected [P, 3] with P in 1..{NO_CANDIDATE - 1}, got {points.shape}")
    w["body_anchor"] = _floats(weights, "body_anchor", (P, 3))
    w["body_anchor_shape"] = _floats(weights, "body_anchor_shape", (B, P, 3))
    n = w["body_anchor_normal"] = _floats(weights, "body_anchor_normal", (P, 3))
    length = np.linalg.norm(n.astype(np.float64), axis=1)
    if np.any((length != 0.0) & (np.abs(length - 1.0) > BODY_NORMAL_TOLERANCE)):
        raise AssetError("body_anchor_normal: each row must be a unit vector, or zero for a point that never anchors")
    idx = np.asarray(weights["body_anchor_skin_indices"])
    if idx.ndim != 2 or idx.shape[0] != P or not 1 <= idx.shape[1] <= MAX_INFLUENCES:
        raise AssetError(f"body_anchor_skin_indices: expected [P={P}, K] with K in 1..{MAX_INFLUENCES}, got {idx.shape}")
    w["body_anchor_skin_indices"] = _ints(weights, "body_anchor_skin_indices", idx.shape, 0, J)
    w["body_anchor_skin_weights"] = _floats(weights, "body_anchor_skin_weights", idx.shape)
    _skin_weights(w, "body_anchor_skin_weights", idx.shape[1])
    if candidates is not None:
        c = np.asarray(candidates)
        if c.ndim != 2 or c.shape[0] != N or not 1 <= c.shape[1] <= MAX_CONTACT_CANDIDATES:
            raise AssetError(f"{BODY_CONTACT_CANDIDATES_KEY}: expected [N={N}, C] with C in "
                             f"1..{MAX_CONTACT_CANDIDATES}, got {c.shape}")
        if not np.issubdtype(c.dtype, np.integer) or np.any((c < 0) | ((c >= P) & (c != NO_CANDIDATE))):
            raise AssetError(f"{BODY_CONTACT_CANDIDATES_KEY}: each entry must be a point index below P = {P} "
                             f"or {NO_CANDIDATE} (an empty slot)")
        w[BODY_CONTACT_CANDIDATES_KEY] = c.astype(np.uint16)
    if ring is not None:
        r = np.asarray(ring)
        if r.ndim != 2 or r.shape[0] != P or not 3 <= r.shape[1] <= MAX_POINT_RING:
            raise AssetError(f"{BODY_CONTACT_RING_KEY}: expected [P={P}, R] with R in 3..{MAX_POINT_RING}, got {r.shape}")
        empty = r == NO_CANDIDATE
        used = np.sum(~empty, axis=1)
        if (not np.issubdtype(r.dtype, np.integer) or np.any((r < 0) | ((r >= P) & ~empty))
                or np.any(empty[:, :-1] & ~empty[:, 1:]) or np.any((used > 0) & (used < 3))):
            raise AssetError(f"{BODY_CONTACT_RING_KEY}: each row must be 3..R point indices below P = {P}, then "
                             f"{NO_CANDIDATE} (or {NO_CANDIDATE} throughout: no ring)")
        w[BODY_CONTACT_RING_KEY] = r.astype(np.uint16)


def _to_fp16(a, key):
    with np.errstate(over="ignore"):
        h = a.astype(np.float16)
    if not np.all(np.isfinite(h)):
        raise AssetError(f"{key}: values overflow fp16")
    return h


def _conf_block(w):
    c = w["counts"]
    conf = bytearray(CONF_SIZE)
    values = [c[k] for k in _CONF_U32_FIELDS[:10]] + [ACTIVATIONS[w["lp_activation"]],
                                                      ACTIVATIONS[w["dec_activation"]], c["input_count"]]
    struct.pack_into("<13I", conf, 0, *values)
    struct.pack_into("<4f", conf, 52, *w["dt_range_s"], *w["beta_range"])
    struct.pack_into("<12f", conf, 68, *w["material_min"], *w["material_max"], *w["material_default"])
    struct.pack_into("<f", conf, 116, float(w["train_fps"]))
    return np.frombuffer(bytes(conf), dtype=np.uint8)


def _sections(w, onnx_models=None):
    """(fourcc, dtype code, array) in file order."""
    c = w["counts"]
    jnam = np.zeros((c["joint_count"], JOINT_NAME_BYTES), dtype=np.uint8)
    for k, n in enumerate(w["joint_names"]):
        b = n.encode("utf-8")
        jnam[k, :len(b)] = np.frombuffer(b, dtype=np.uint8)
    text = lambda s: np.frombuffer(s.encode("utf-8"), dtype=np.uint8)
    nado, nadf = normal_adjacency(w["faces"], c["vertex_count"])
    f16_or_f32 = lambda a: (DTYPE_F16, a) if a.dtype == np.float16 else (DTYPE_F32, a)
    int8 = is_int8(w)
    out = [("CONF", DTYPE_U8, _conf_block(w)), ("NAME", DTYPE_U8, text(w["garment_name"]))]
    if "metadata_json" in w:
        out.append(("META", DTYPE_U8, text(w["metadata_json"])))
    out += [("JNAM", DTYPE_U8, jnam), ("JPAR", DTYPE_I32, w["joint_parents"]),
            ("JTPL", DTYPE_F32, w["joint_template"]), ("JSHP", DTYPE_F32, w["joint_shapedirs"]),
            ("JINP", DTYPE_U32, w["input_joints"]), ("TMPL", DTYPE_F32, w["template"]),
            ("SHPB", DTYPE_F32, w["shape_blend"]), ("FACE", DTYPE_U32, w["faces"]),
            ("NADO", DTYPE_U32, nado), ("NADF", DTYPE_U32, nadf),
            ("SKNI", DTYPE_U16, w["skin_indices"]), ("SKNW", DTYPE_F32, w["skin_weights"]),
            ("XMEA", DTYPE_F32, w["x_mean"]), ("XSTD", DTYPE_F32, w["x_std"]),
            ("ZMEA", DTYPE_F32, w["z_mean"]), ("ZSTD", DTYPE_F32, w["z_std"]),
            ("ZMIN", DTYPE_F32, w["z_min"]), ("ZMAX", DTYPE_F32, w["z_max"])]
    for prefix, tag in (("lp", "LP"), ("dec", "DC")):
        for i in range(w["counts"][f"{prefix}_layer_count"]):
            if int8:
                out += [(f"{tag}W{i}", DTYPE_I8, w[f"{prefix}.{i}.weight"]),
                        (f"{tag}S{i}", DTYPE_F32, w[f"{prefix}.{i}.weight_scale"]),
                        (f"{tag}A{i}", DTYPE_F32, w[f"{prefix}.{i}.input_scale"])]
            else:
                out.append((f"{tag}W{i}", *f16_or_f32(w[f"{prefix}.{i}.weight"])))
            out.append((f"{tag}B{i}", DTYPE_F32, w[f"{prefix}.{i}.bias"]))
    if has_int8_blend_shapes(w):
        out += [("BLND", DTYPE_I8, w["blend_shapes_int8"]), ("BLSC", DTYPE_F32, w["blend_shape_scales"])]
    else:
        out.append(("BLND", *f16_or_f32(w["blend_shapes"])))
    if "pinned" in w:
        out.append(("PINS", DTYPE_U32, w["pinned"]))
    if "body_anchor" in w:
        out += [("BANC", DTYPE_F32, w["body_anchor"]), ("BASH", DTYPE_F32, w["body_anchor_shape"]),
                ("BANN", DTYPE_F32, w["body_anchor_normal"]),
                ("BASI", DTYPE_U16, w["body_anchor_skin_indices"]), ("BASW", DTYPE_F32, w["body_anchor_skin_weights"])]
        if BODY_CONTACT_CANDIDATES_KEY in w:
            out.append(("BACA", DTYPE_U16, w[BODY_CONTACT_CANDIDATES_KEY]))
        if BODY_CONTACT_RING_KEY in w:
            out.append(("BARG", DTYPE_U16, w[BODY_CONTACT_RING_KEY]))
    for fourcc, model in (onnx_models or {}).items():
        out.append((fourcc, DTYPE_U8, np.frombuffer(model, dtype=np.uint8)))
    return out


def _align(n):
    return (n + ALIGN - 1) // ALIGN * ALIGN


def write_asset(path_or_file, weights, fp16=False, onnx=False, onnx_weights=None):
    """Validates `weights`, writes the asset to a path or binary file object (None = don't write), returns the bytes.

    fp16 stores the LP/decoder weight matrices and BLND as fp16 (with int8 networks, BLND only); onnx adds OXLP/OXDC
    (pleat.onnx_export), built from onnx_weights where given: an int8 asset carries the float networks it was
    quantised from, which the ONNX Runtime backend runs as before."""
    w = validate_weights(weights, fp16=fp16)
    models = None
    if onnx and onnx_weights is not None:
        from pleat import onnx_export
        fw = validate_weights(onnx_weights)
        models = {"OXLP": onnx_export.latent_predictor_model(fw), "OXDC": onnx_export.decoder_model(fw)}
    elif onnx:
        if is_int8(w):
            raise AssetError("onnx: an int8 network needs the float weights it came from (onnx_weights)")
        from pleat import onnx_export
        models = {"OXLP": onnx_export.latent_predictor_model(w), "OXDC": onnx_export.decoder_model(w)}
    sections = _sections(w, models)
    if len(sections) > 256:
        raise AssetError("more than 256 sections")
    table_end = HEADER_SIZE + SECTION_ENTRY_SIZE * len(sections)
    offset = _align(table_end)
    table = bytearray()
    payloads = []
    for fourcc, dtype, array in sections:
        array = np.ascontiguousarray(array, dtype=_NUMPY_OF_DTYPE[dtype])
        dims = list(array.shape) if array.ndim else [1]
        if not 1 <= len(dims) <= 4:
            raise AssetError(f"section {fourcc}: rank {len(dims)}")
        data = array.tobytes()
        table += struct.pack("<4sIII QQ 4I", fourcc.encode("ascii"), dtype, len(dims), 0, offset, len(data),
                             *(dims + [1] * (4 - len(dims))))
        payloads.append((offset, data))
        offset = _align(offset + len(data))
    file_size = payloads[-1][0] + len(payloads[-1][1])
    buf = bytearray(file_size)
    flags = (FLAG_FP16 if any(a.dtype == np.float16 for _, _, a in sections) else 0) | (
        FLAG_INT8 if is_int8(w) else 0) | (FLAG_INT8_RANGED_INPUTS if w.get("int8_ranged_inputs") else 0) | (
        FLAG_INT8_BLEND_SHAPES if has_int8_blend_shapes(w) else 0)
    # the lowest version that describes the file: float assets stay 1.2, byte for byte what earlier writers made
    minor = 4 if flags & FLAG_INT8_BLEND_SHAPES else 3 if flags & FLAG_INT8 else 2
    struct.pack_into("<8sHHIQIIQI", buf, 0, MAGIC, VERSION_MAJOR, minor, HEADER_SIZE, file_size,
                     len(sections), flags, HEADER_SIZE, 0)
    buf[HEADER_SIZE:table_end] = table
    for off, data in payloads:
        buf[off:off + len(data)] = data
    struct.pack_into("<I", buf, CHECKSUM_OFFSET, zlib.crc32(bytes(buf)) & 0xFFFFFFFF)
    data = bytes(buf)
    if path_or_file is not None:
        if isinstance(path_or_file, (str, os.PathLike)):
            from pleat.fileio import write_bytes
            write_bytes(path_or_file, data)   # atomic: a failed write keeps the old file
        else:
            path_or_file.write(data)
    return data


def checksum(data):
    """CRC-32 of the file with the checksum field read as zero."""
    buf = bytearray(data[:HEADER_SIZE])
    buf[CHECKSUM_OFFSET:CHECKSUM_OFFSET + 4] = b"\0\0\0\0"
    return zlib.crc32(bytes(data[HEADER_SIZE:]), zlib.crc32(bytes(buf))) & 0xFFFFFFFF


def inspect_asset(data, verify_checksum=True):
    """Structure only: (header dict, [section dicts]) after the checks the C loader does before making pointers."""
    data = bytes(data)
    if len(data) < 16:
        raise AssetError(f"{len(data)} bytes: shorter than the header", "TRUNCATED")
    if data[:8] != MAGIC:
        raise AssetError(f"bad magic {data[:8]!r}", "BAD_MAGIC")
    major, minor, header_size = struct.unpack_from("<HHI", data, 8)
    if major < VERSION_MAJOR:
        raise AssetError(f"version {major}.{minor} is older than {VERSION_MAJOR}.x", "LEGACY_VERSION")
    if major > VERSION_MAJOR:
        raise AssetError(f"version {major}.{minor} is newer than {VERSION_MAJOR}.x", "UNSUPPORTED_VERSION")
    if len(data) < HEADER_SIZE:
        raise AssetError(f"{len(data)} bytes: shorter than the header", "TRUNCATED")
    if header_size < HEADER_SIZE:
        raise AssetError(f"header_size {header_size} < {HEADER_SIZE}", "MALFORMED_ASSET")
    file_size, section_count, flags, table_offset, stored_crc = struct.unpack_from("<QIIQI", data, 16)
    if file_size > len(data):
        raise AssetError(f"file_size {file_size} but only {len(data)} bytes", "TRUNCATED")
    if file_size != len(data):
        raise AssetError(f"file_size {file_size} != buffer size {len(data)}", "MALFORMED_ASSET")
    if header_size > file_size:
        raise AssetError("header_size beyond the file", "TRUNCATED")
    if verify_checksum and checksum(data) != stored_crc:
        raise AssetError(f"CRC-32 {checksum(data):08x} != stored {stored_crc:08x}", "CHECKSUM_MISMATCH")
    if major == VERSION_MAJOR and minor <= VERSION_MINOR and flags & ~KNOWN_FLAGS:
        raise AssetError(f"unknown flags 0x{flags:x}", "MALFORMED_ASSET")
    if flags & FLAG_INT8_RANGED_INPUTS and not flags & FLAG_INT8:
        raise AssetError("flag 0x4 (int8 ranged inputs) without 0x2 (int8 networks)", "MALFORMED_ASSET")
    if not 1 <= section_count <= 256:
        raise AssetError(f"section_count {section_count}", "MALFORMED_ASSET")
    if table_offset < header_size or table_offset + section_count * SECTION_ENTRY_SIZE > file_size:
        raise AssetError("section table outside the file", "MALFORMED_ASSET")
    header = dict(version=(major, minor), header_size=header_size, file_size=file_size, section_count=section_count,
                  flags=flags, section_table_offset=table_offset, checksum=stored_crc)
    sections, seen, spans = [], set(), []
    table_end = table_offset + section_count * SECTION_ENTRY_SIZE
    for i in range(section_count):
        raw, dtype, rank, _, off, size, *dims = struct.unpack_from("<4sIII QQ 4I", data,
                                                                   table_offset + i * SECTION_ENTRY_SIZE)
        try:
            fourcc = raw.decode("ascii")
        except UnicodeDecodeError:
            raise AssetError(f"section {i}: fourcc {raw!r} is not ASCII", "MALFORMED_ASSET") from None
        if fourcc in seen:
            raise AssetError(f"duplicate section {fourcc}", "MALFORMED_ASSET")
        seen.add(fourcc)
        if dtype not in _NUMPY_OF_DTYPE:
            raise AssetError(f"section {fourcc}: unknown dtype {dtype}", "MALFORMED_ASSET")
        if not 1 <= rank <= 4 or any(d != 1 for d in dims[rank:]):
            raise AssetError(f"section {fourcc}: rank {rank} / dims {dims}", "MALFORMED_ASSET")
        if off % ALIGN or off < table_end or off > file_size or size > file_size - off:
            raise AssetError(f"section {fourcc}: [{off}, +{size}) misaligned or outside the file", "MALFORMED_ASSET")
        if int(np.prod(dims, dtype=object)) * _NUMPY_OF_DTYPE[dtype].itemsize != size:
            raise AssetError(f"section {fourcc}: size {size} != dims {dims[:rank]} × dtype", "MALFORMED_ASSET")
        spans.append((off, off + size, fourcc))
        sections.append(dict(fourcc=fourcc, dtype=dtype, rank=rank, offset=off, size=size, dims=tuple(dims[:rank])))
    spans.sort()
    for (a0, a1, fa), (b0, b1, fb) in zip(spans, spans[1:]):
        if b0 < a1:
            raise AssetError(f"sections {fa} and {fb} overlap", "MALFORMED_ASSET")
    return header, sections


def _array(data, s):
    return np.frombuffer(data, dtype=_NUMPY_OF_DTYPE[s["dtype"]], count=s["size"] // _NUMPY_OF_DTYPE[s["dtype"]].itemsize,
                         offset=s["offset"]).reshape(s["dims"]).copy()


def read_conf(block):
    raw = bytes(block)
    c = dict(zip(_CONF_U32_FIELDS, struct.unpack_from("<13I", raw, 0)))
    f = struct.unpack_from("<4f12ff", raw, 52)
    c.update(dt_range_s=f[0:2], beta_range=f[2:4], material_min=f[4:8], material_max=f[8:12],
             material_default=f[12:16], train_fps=f[16])
    return c


def read_asset(data, verify_checksum=True):
    """Parses and validates an asset; returns the weights dict (same keys as the weights file). Weight matrices and
    blend_shapes stored as fp16 come back as float16; int8 blend shapes (1.4) as 'blend_shapes_int8' and
    'blend_shape_scales', with 'blend_shapes' their float32 values as the runtime reads them. The ONNX sections, if
    present, come back as bytes under 'onnx_latent_predictor' / 'onnx_decoder'."""
    data = bytes(data)
    header, sections = inspect_asset(data, verify_checksum)
    by = {s["fourcc"]: s for s in sections}

    def get(fourcc, dtypes, dims=None):
        if fourcc not in by:
            raise AssetError(f"required section {fourcc} missing", "INVALID_ASSET_DATA")
        s = by[fourcc]
        if s["dtype"] not in dtypes:
            raise AssetError(f"section {fourcc}: dtype {s['dtype']}, expected {dtypes}", "INVALID_ASSET_DATA")
        if dims is not None and s["dims"] != tuple(dims):
            raise AssetError(f"section {fourcc}: dims {s['dims']}, expected {tuple(dims)}", "INVALID_ASSET_DATA")
        return _array(data, s)

    conf_block = get("CONF", (DTYPE_U8,), (CONF_SIZE,))
    if np.any(conf_block[120:]):
        raise AssetError("CONF: reserved bytes 120.. must be zero", "INVALID_ASSET_DATA")
    conf = read_conf(conf_block)
    if any(conf[f"{p}_activation"] not in ACTIVATION_NAMES for p in ("lp", "dec")):
        raise AssetError("CONF: unknown activation", "INVALID_ASSET_DATA")
    if not (1 <= conf["lp_layer_count"] <= MAX_LAYERS and 1 <= conf["dec_layer_count"] <= MAX_LAYERS):
        raise AssetError("CONF: layer count outside 1..10", "INVALID_ASSET_DATA")
    N, F, J, Jin = conf["vertex_count"], conf["face_count"], conf["joint_count"], conf["input_joint_count"]
    K, B, L, D, I = (conf[k] for k in ("influence_count", "beta_count", "latent_count", "blend_count", "input_count"))
    if I != input_count(L, Jin, B):
        raise AssetError(f"CONF: input_count {I} != formula {input_count(L, Jin, B)}", "INVALID_ASSET_DATA")
    f = lambda t: get(t, (DTYPE_F32,))
    w = {}
    try:
        w["garment_name"] = get("NAME", (DTYPE_U8,)).tobytes().decode("utf-8")
        if "META" in by:
            w["metadata_json"] = get("META", (DTYPE_U8,)).tobytes().decode("utf-8")
        jnam = get("JNAM", (DTYPE_U8,), (J, JOINT_NAME_BYTES))
        w["joint_names"] = np.array([row.tobytes().split(b"\0")[0].decode("utf-8") for row in jnam])
    except UnicodeDecodeError as e:
        raise AssetError(f"text section is not utf-8: {e}", "INVALID_ASSET_DATA") from None
    w["joint_parents"] = get("JPAR", (DTYPE_I32,), (J,))
    w["joint_template"] = get("JTPL", (DTYPE_F32,), (J, 3))
    w["joint_shapedirs"] = get("JSHP", (DTYPE_F32,), (B, J, 3))
    w["input_joints"] = get("JINP", (DTYPE_U32,), (Jin,))
    w["template"] = get("TMPL", (DTYPE_F32,), (N, 3))
    w["shape_blend"] = get("SHPB", (DTYPE_F32,), (B, N, 3))
    w["faces"] = get("FACE", (DTYPE_U32,), (F, 3))
    w["skin_indices"] = get("SKNI", (DTYPE_U16,), (N, K))
    w["skin_weights"] = get("SKNW", (DTYPE_F32,), (N, K))
    for key, tag, n in (("x_mean", "XMEA", I), ("x_std", "XSTD", I), ("z_mean", "ZMEA", L), ("z_std", "ZSTD", L),
                        ("z_min", "ZMIN", L), ("z_max", "ZMAX", L)):
        w[key] = get(tag, (DTYPE_F32,), (n,))
    for prefix, tag in (("lp", "LP"), ("dec", "DC")):
        for i in range(conf[f"{prefix}_layer_count"]):
            if header["flags"] & FLAG_INT8:
                w[f"{prefix}.{i}.weight"] = get(f"{tag}W{i}", (DTYPE_I8,))
                w[f"{prefix}.{i}.weight_scale"] = get(f"{tag}S{i}", (DTYPE_F32,))
                w[f"{prefix}.{i}.input_scale"] = get(f"{tag}A{i}", (DTYPE_F32,), (1,))
            else:
                w[f"{prefix}.{i}.weight"] = get(f"{tag}W{i}", (DTYPE_F32, DTYPE_F16))
            w[f"{prefix}.{i}.bias"] = get(f"{tag}B{i}", (DTYPE_F32,))
        w[f"{prefix}_activation"] = ACTIVATION_NAMES[conf[f"{prefix}_activation"]]
    if header["flags"] & FLAG_INT8_RANGED_INPUTS:
        if (w["lp_activation"], w["dec_activation"]) != ("relu", "relu"):
            raise AssetError("flag 0x4 (int8 ranged inputs) needs ReLU networks", "INVALID_ASSET_DATA")
        w["int8_ranged_inputs"] = True
    if header["flags"] & FLAG_INT8_BLEND_SHAPES:
        w["blend_shapes_int8"] = get("BLND", (DTYPE_I8,), (D, N, 3))
        w["blend_shape_scales"] = get("BLSC", (DTYPE_F32,), (D,))
        scales = w["blend_shape_scales"]
        if int(w["blend_shapes_int8"].min(initial=0)) < -127 or not np.all(np.isfinite(scales) & (scales > 0)):
            raise AssetError("BLND/BLSC: int8 blend shapes outside -127..127 or a scale not positive",
                             "INVALID_ASSET_DATA")
        w["blend_shapes"] = blend_shape_values(w["blend_shapes_int8"], w["blend_shape_scales"])
    else:
        w["blend_shapes"] = get("BLND", (DTYPE_F32, DTYPE_F16), (D, N, 3))
    if "PINS" in by:
        w["pinned"] = get("PINS", (DTYPE_U32,))
    contact = [t for t in BODY_CONTACT_SECTIONS if t in by]
    if contact:
        if len(contact) != len(BODY_CONTACT_SECTIONS):
            raise AssetError(f"body contact: sections {contact} without the rest of {list(BODY_CONTACT_SECTIONS)}",
                             "INVALID_ASSET_DATA")
        Ka = by["BASI"]["dims"][1] if len(by["BASI"]["dims"]) == 2 else 0
        P = by["BANC"]["dims"][0] if "BACA" in by and by["BANC"]["dims"] else N    # 1.1: one point per vertex
        w["body_anchor"] = get("BANC", (DTYPE_F32,), (P, 3))
        w["body_anchor_shape"] = get("BASH", (DTYPE_F32,), (B, P, 3))
        w["body_anchor_normal"] = get("BANN", (DTYPE_F32,), (P, 3))
        w["body_anchor_skin_indices"] = get("BASI", (DTYPE_U16,), (P, Ka))
        w["body_anchor_skin_weights"] = get("BASW", (DTYPE_F32,), (P, Ka))
        if "BACA" in by:
            C = by["BACA"]["dims"][1] if len(by["BACA"]["dims"]) == 2 else 0
            w[BODY_CONTACT_CANDIDATES_KEY] = get("BACA", (DTYPE_U16,), (N, C))
        if "BARG" in by:
            R = by["BARG"]["dims"][1] if len(by["BARG"]["dims"]) == 2 else 0
            w[BODY_CONTACT_RING_KEY] = get("BARG", (DTYPE_U16,), (P, R))
    elif "BACA" in by or "BARG" in by:
        raise AssetError("body contact: BACA or BARG without the body points", "INVALID_ASSET_DATA")
    w["dt_range_s"] = np.array(conf["dt_range_s"], dtype=np.float32)
    w["beta_range"] = np.array(conf["beta_range"], dtype=np.float32)
    for key in ("material_min", "material_max", "material_default"):
        w[key] = np.array(conf[key], dtype=np.float32)
    w["train_fps"] = np.float32(conf["train_fps"])
    try:
        checked = validate_weights(w)
    except AssetError as e:
        raise AssetError(str(e), "INVALID_ASSET_DATA") from None
    for key in ("lp_layer_count", "dec_layer_count"):
        if checked["counts"][key] != conf[key]:
            raise AssetError(f"CONF {key} disagrees with the sections", "INVALID_ASSET_DATA")
    nado, nadf = normal_adjacency(w["faces"], N)
    if not (np.array_equal(get("NADO", (DTYPE_U32,), (N + 1,)), nado)
            and np.array_equal(get("NADF", (DTYPE_U32,), (3 * F,)), nadf)):
        raise AssetError("NADO/NADF do not match the faces", "INVALID_ASSET_DATA")
    for key, tag in (("onnx_latent_predictor", "OXLP"), ("onnx_decoder", "OXDC")):
        if tag in by:
            w[key] = get(tag, (DTYPE_U8,)).tobytes()
    return w


def load_weights(path):
    """Reads a weights file (.npz or .safetensors). In .safetensors the string-valued keys (garment_name,
    metadata_json, lp_activation, dec_activation, and joint_names as a JSON list) live in the header metadata."""
    path = Path(path)
    if path.suffix == ".safetensors":
        from safetensors import safe_open
        w = {}
        with safe_open(str(path), framework="np") as f:
            for key in f.keys():
                w[key] = f.get_tensor(key)
            meta = f.metadata() or {}
        for key, value in meta.items():
            w[key] = json.loads(value) if key == "joint_names" else value
        return w
    with np.load(path, allow_pickle=False) as z:
        w = {k: z[k] for k in z.files}
    for k, v in list(w.items()):
        if v.dtype.kind == "U" and v.ndim == 0:
            w[k] = str(v)
    return w


def save_weights(path, weights):
    """Writes a weights dict as .npz or .safetensors (the inverse of load_weights), atomically (pleat.fileio)."""
    from pleat.fileio import save_npz, write_bytes
    path = Path(path)
    strings = {k: v for k, v in weights.items() if isinstance(v, str) or k == "joint_names"}
    arrays = {k: np.ascontiguousarray(v) for k, v in weights.items() if k not in strings and v is not None}
    if path.suffix == ".safetensors":
        from safetensors.numpy import save
        meta = {k: (json.dumps([str(n) for n in v]) if k == "joint_names" else v) for k, v in strings.items()}
        arrays = {k: (np.asarray(v, dtype=np.float32) if np.asarray(v).ndim == 0 else v) for k, v in arrays.items()}
        write_bytes(path, save(arrays, metadata=meta))
    else:
        save_npz(path, **arrays, **{k: (np.array([str(n) for n in v]) if k == "joint_names" else np.array(v))
                                    for k, v in strings.items()})
