"""ctypes binding over the C runtime libpleat.so (sdk/include/pleat/pleat.h), for evaluation and tests.

    with Context() as ctx:
        asset = ctx.load_asset(path_or_bytes)
        inst = ctx.create_instance(asset, beta=beta, material=material)
        positions, normals = inst.step(rotations [J, 4], root_translation [3], root_rotation [4], dt_s)
        inst.latent, inst.last_result

The library is found through $PLEAT_LIBRARY, then $PLEAT_BUILD_DIR, then the newest build/*/libpleat.so (or
build/*/sdk/libpleat.so) of the repository. Negative plResult values raise PleatError (with plResultString's name);
positive ones (CLAMPED, NUMERIC_RESET) are kept in `last_result`.
"""
import ctypes as C
import os
from pathlib import Path

import numpy as np

from pleat import REPO_ROOT


# plInstanceDef.body_contact's modes (pleat.h BODY CONTACT)
BODY_CONTACT_OFF, BODY_CONTACT_ON, BODY_CONTACT_FAST = 0, 1, 2


def contact_mode(body_contact):
    """True/False or a mode (0, 1, 2, "fast") → the plInstanceDef.body_contact value."""
    if body_contact == "fast":
        return BODY_CONTACT_FAST
    return int(body_contact) if not isinstance(body_contact, bool) else int(body_contact)


class PleatError(RuntimeError):
    def __init__(self, code, name, what):
        super().__init__(f"{what}: {name} ({code})")
        self.code = code
        self.name = name


class _Context(C.Structure):
    _fields_ = [("index1", C.c_uint32), ("generation", C.c_uint32)]


class _Handle(C.Structure):
    """plAsset / plInstance: slot index and generation, then the context's handle (pleat.h, HANDLES)."""
    _fields_ = [("index1", C.c_uint32), ("generation", C.c_uint32), ("context", _Context)]


class _ContextDef(C.Structure):
    _fields_ = [("alloc", C.c_void_p), ("free", C.c_void_p), ("allocator_context", C.c_void_p),
                ("enqueue_task", C.c_void_p), ("finish_task", C.c_void_p), ("task_context", C.c_void_p),
                ("worker_count", C.c_uint32), ("log", C.c_void_p), ("log_context", C.c_void_p),
                ("force_scalar", C.c_int), ("max_isa", C.c_int), ("internal_cookie", C.c_int32)]


class _AssetDef(C.Structure):
    _fields_ = [("data", C.c_void_p), ("size", C.c_size_t), ("path", C.c_char_p), ("flags", C.c_uint32),
                ("internal_cookie", C.c_int32)]


class _AssetInfo(C.Structure):
    _fields_ = [(k, C.c_uint32) for k in ("vertex_count", "face_count", "joint_count", "input_joint_count",
                                          "influence_count", "beta_count", "latent_count", "blend_count",
                                          "input_count", "lp_layer_count", "dec_layer_count")] + [
        ("weights_fp16", C.c_int), ("dt_min_s", C.c_float), ("dt_max_s", C.c_float), ("beta_min", C.c_float),
        ("beta_max", C.c_float), ("material_min", C.c_float * 4), ("material_max", C.c_float * 4),
        ("material_default", C.c_float * 4), ("train_fps", C.c_float), ("name", C.c_char * 65),
        ("meta_json", C.c_void_p), ("meta_json_size", C.c_size_t), ("has_onnx_lp", C.c_int),
        ("has_onnx_decoder", C.c_int), ("pinned_count", C.c_uint32), ("has_body_contact", C.c_int)]


class _InstanceDef(C.Structure):
    _fields_ = [("asset", _Handle), ("joint_map", C.c_void_p), ("joint_map_count", C.c_uint32),
                ("engine_joint_count", C.c_uint32), ("beta", C.c_void_p), ("beta_count", C.c_uint32),
                ("material", C.c_void_p), ("mlp_backend", C.c_int), ("onnxruntime_library", C.c_char_p),
                ("gpu_mode", C.c_int), ("host_position_buffer", C.c_uint32), ("host_normal_buffer", C.c_uint32),
                ("network_rate_hz", C.c_float), ("body_contact", C.c_int), ("body_contact_offset_m", C.c_float),
                ("gpu_share", _Handle), ("user_data", C.c_void_p), ("internal_cookie", C.c_int32)]


class _Vec3(C.Structure):
    _fields_ = [("x", C.c_float), ("y", C.c_float), ("z", C.c_float)]


class _Quat(C.Structure):
    _fields_ = [("x", C.c_float), ("y", C.c_float), ("z", C.c_float), ("w", C.c_float)]


class _RestJoint(C.Structure):
    _fields_ = [("parent", C.c_int32), ("position", _Vec3), ("local_translation", _Vec3), ("local_rotation", _Quat)]


class _FrameInput(C.Structure):
    _fields_ = [("joint_rotations", C.c_void_p), ("joint_count", C.c_uint32), ("joint_stride_bytes", C.c_uint32),
                ("root_translation", _Vec3), ("root_rotation", _Quat), ("dt_s", C.c_float)]


class _StepOutput(C.Structure):
    _fields_ = [("positions", C.c_void_p), ("position_stride_bytes", C.c_uint32), ("normals", C.c_void_p),
                ("normal_stride_bytes", C.c_uint32), ("vertex_capacity", C.c_uint32)]


class _Version(C.Structure):
    _fields_ = [("major", C.c_uint32), ("minor", C.c_uint32), ("patch", C.c_uint32), ("asset_major", C.c_uint32)]


BACKENDS = {"pleat": 0, "onnxruntime": 1, "gpu": 2}  # plMlpBackend
GPU_MODES = {"none": 0, "host_context": 1, "headless": 2}   # plGpuMode
KERNEL_SETS = ["scalar", "avx2", "avx512"]        # plKernelSet, by value
RESULT_CLAMPED, RESULT_NUMERIC_RESET = 1, 2


def find_library():
    """Path of libpleat.so, or None."""
    if os.environ.get("PLEAT_LIBRARY"):
        return Path(os.environ["PLEAT_LIBRARY"])
    candidates = []
    if os.environ.get("PLEAT_BUILD_DIR"):
        b = Path(os.environ["PLEAT_BUILD_DIR"])
        candidates += [b / "libpleat.so", b / "sdk" / "libpleat.so"]
    found = [p for p in candidates if p.is_file()]
    if found:
        return found[0]
    found = list(REPO_ROOT.glob("build*/libpleat.so")) + list(REPO_ROOT.glob("build*/*/libpleat.so")) + \
        list(REPO_ROOT.glob("build*/*/sdk/libpleat.so"))
    if found:
        return max(found, key=lambda p: p.stat().st_mtime)
    # outside a checkout: an installed library (cmake --install) on the system's search path
    import ctypes.util
    name = ctypes.util.find_library("pleat")
    return Path(name) if name else None


_lib = None


def load_library(path=None):
    """Loads libpleat.so once and declares the signatures used here."""
    global _lib
    if _lib is not None and path is None:
        return _lib
    path = path or find_library()
    if path is None:
        raise OSError("libpleat.so not found (set PLEAT_LIBRARY or PLEAT_BUILD_DIR, build with CMake into build/, or "
                      "install it where the system's loader finds it)")
    lib = C.CDLL(str(path))
    P = C.POINTER
    sig = {
        "plResultString": (C.c_char_p, [C.c_int]),
        "plGetVersion": (_Version, []),
        "plDefaultContextDef": (_ContextDef, []),
        "plCreateContext": (C.c_int, [P(_ContextDef), P(_Context)]),
        "plDestroyContext": (C.c_int, [_Context]),
        "plContext_GetLiveBytes": (C.c_int, [_Context, P(C.c_uint64)]),
        "plContext_GetKernelSet": (C.c_int, [_Context, P(C.c_int)]),
        "plDefaultAssetDef": (_AssetDef, []),
        "plLoadAsset": (C.c_int, [_Context, P(_AssetDef), P(_Handle)]),
        "plDestroyAsset": (C.c_int, [_Handle]),
        "plAsset_GetInfo": (C.c_int, [_Handle, P(_AssetInfo)]),
        "plAsset_GetJointName": (C.c_int, [_Handle, C.c_uint32, P(C.c_char_p)]),
        "plDefaultInstanceDef": (_InstanceDef, []),
        "plCreateInstance": (C.c_int, [_Context, P(_InstanceDef), P(_Handle)]),
        "plDestroyInstance": (C.c_int, [_Handle]),
        "plInstance_Step": (C.c_int, [_Handle, P(_FrameInput), P(_StepOutput)]),
        "plInstance_Reset": (C.c_int, [_Handle]),
        "plInstance_SetNetworkRate": (C.c_int, [_Handle, C.c_float]),
        "plInstance_SetBodyContact": (C.c_int, [_Handle, C.c_int, C.c_float]),
        "plInstance_SetShape": (C.c_int, [_Handle, C.c_void_p, C.c_uint32]),
        "plInstance_SetMaterial": (C.c_int, [_Handle, C.c_void_p]),
        "plInstance_GetSkinMatrices": (C.c_int, [_Handle, C.c_void_p, C.c_uint32]),
        "plInstance_GetLatent": (C.c_int, [_Handle, C.c_void_p, C.c_uint32]),
        "plInstance_GetBlendWeights": (C.c_int, [_Handle, C.c_void_p, C.c_uint32]),
        "plAsset_GetRestPose": (C.c_int, [_Handle, P(_RestJoint), C.c_uint32]),
        "plInstance_GetRestPose": (C.c_int, [_Handle, P(_RestJoint), C.c_uint32]),
    }
    for name, (restype, argtypes) in sig.items():
        fn = getattr(lib, name)
        fn.restype, fn.argtypes = restype, argtypes
    if path is None or _lib is None:
        _lib = lib
    return lib


def library_version(path=None):
    """(major, minor, patch, asset_major) of the loaded library (plGetVersion)."""
    v = load_library(path).plGetVersion()
    return v.major, v.minor, v.patch, v.asset_major


def _check(lib, result, what):
    if result < 0:
        raise PleatError(result, lib.plResultString(result).decode(), what)
    return result


def _rest_pose(lib, fn, handle, joint_count):
    """plAsset_GetRestPose / plInstance_GetRestPose as arrays: parents [J], positions [J, 3], local_translations
    [J, 3], local_rotations [J, 4] (x, y, z, w)."""
    joints = (_RestJoint * joint_count)()
    _check(lib, getattr(lib, fn)(handle, joints, joint_count), fn)
    vec = lambda v: (v.x, v.y, v.z)
    return {"parents": np.array([j.parent for j in joints], np.int32),
            "positions": np.array([vec(j.position) for j in joints], np.float32).reshape(joint_count, 3),
            "local_translations": np.array([vec(j.local_translation) for j in joints],
                                           np.float32).reshape(joint_count, 3),
            "local_rotations": np.array([vec(j.local_rotation) + (j.local_rotation.w,) for j in joints],
                                        np.float32).reshape(joint_count, 4)}


def _f32(a, shape):
    return np.ascontiguousarray(np.asarray(a, np.float32).reshape(shape))


class Context:
    def __init__(self, force_scalar=False, library=None, max_isa=None):
        """max_isa: the widest kernel set the context may take ("scalar", "avx2", "avx512"; default the widest);
        force_scalar=True is max_isa="scalar"."""
        self.lib = load_library(library)
        d = self.lib.plDefaultContextDef()
        if force_scalar:
            max_isa = "scalar"
        if max_isa is not None:
            d.max_isa = KERNEL_SETS.index(max_isa)
        self.handle = _Context()
        _check(self.lib, self.lib.plCreateContext(C.byref(d), C.byref(self.handle)), "plCreateContext")

    @property
    def live_bytes(self):
        n = C.c_uint64()
        _check(self.lib, self.lib.plContext_GetLiveBytes(self.handle, C.byref(n)), "plContext_GetLiveBytes")
        return n.value

    @property
    def kernel_set(self):
        """The CPU kernels the context runs: "scalar", "avx2" or "avx512" (plContext_GetKernelSet; "avx512": the AVX2
        kernels, with plStepInstances's batched networks and blend shapes in AVX-512)."""
        n = C.c_int()
        _check(self.lib, self.lib.plContext_GetKernelSet(self.handle, C.byref(n)), "plContext_GetKernelSet")
        return KERNEL_SETS[n.value]

    @property
    def uses_avx2(self):
        return self.kernel_set in ("avx2", "avx512")

    def load_asset(self, source, skip_checksum=False):
        """source: bytes or a path."""
        return Asset(self, source, skip_checksum)

    def create_instance(self, asset, **kw):
        return Instance(self, asset, **kw)

    def close(self):
        if self.handle.index1:
            _check(self.lib, self.lib.plDestroyContext(self.handle), "plDestroyContext")
            self.handle = _Context()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class Asset:
    def __init__(self, context, source, skip_checksum=False):
        self.context, lib = context, context.lib
        d = lib.plDefaultAssetDef()
        if isinstance(source, (bytes, bytearray, memoryview)):
            self._data = C.create_string_buffer(bytes(source), len(source))
            d.data, d.size = C.cast(self._data, C.c_void_p), len(source)
        else:
            d.path = os.fsencode(str(source))
        d.flags = 0x2 if skip_checksum else 0
        self.handle = _Handle()
        _check(lib, lib.plLoadAsset(context.handle, C.byref(d), C.byref(self.handle)), "plLoadAsset")
        info = _AssetInfo()
        _check(lib, lib.plAsset_GetInfo(self.handle, C.byref(info)), "plAsset_GetInfo")
        self.info = {name: (list(getattr(info, name)) if isinstance(getattr(info, name), C.Array) else
                            getattr(info, name)) for name, _ in _AssetInfo._fields_ if name != "meta_json"}
        self.info["name"] = info.name.decode("utf-8")
        self.info["meta_json"] = (C.string_at(info.meta_json, info.meta_json_size).decode("utf-8")
                                  if info.meta_json else None)
        names = []
        for k in range(info.joint_count):
            p = C.c_char_p()
            _check(lib, lib.plAsset_GetJointName(self.handle, k, C.byref(p)), "plAsset_GetJointName")
            names.append(p.value.decode("utf-8"))
        self.joint_names = names

    def rest_pose(self):
        """The asset's rest pose for β = 0 (plAsset_GetRestPose), see _rest_pose."""
        return _rest_pose(self.context.lib, "plAsset_GetRestPose", self.handle, self.info["joint_count"])

    def close(self):
        if self.handle.index1 and self.context.handle.index1:
            _check(self.context.lib, self.context.lib.plDestroyAsset(self.handle), "plDestroyAsset")
        self.handle = _Handle()


class Instance:
    """A C instance. step(...) returns float32 numpy copies of positions and normals [N, 3]."""

    def __init__(self, context, asset, beta=None, material=None, backend="pleat", onnxruntime_library=None,
                 gpu="none", network_rate_hz=0.0, body_contact=True, body_contact_offset_m=None, gpu_share=None):
        """body_contact / body_contact_offset_m: plInstanceDef's (None = the SDK's default clearance); gpu_share: an
        Instance of the same asset, GPU mode and backend whose GPU data this one shares (plInstanceDef.gpu_share)."""
        self.context, self.asset, lib = context, asset, context.lib
        self.lib = lib
        d = lib.plDefaultInstanceDef()
        d.asset = asset.handle
        keep = []
        if beta is not None:
            b = _f32(beta, -1)
            keep.append(b)
            d.beta, d.beta_count = b.ctypes.data, b.size
        if material is not None:
            m = _f32(material, 4)
            keep.append(m)
            d.material = m.ctypes.data
        d.mlp_backend = BACKENDS[backend]
        if onnxruntime_library:
            d.onnxruntime_library = os.fsencode(str(onnxruntime_library))
        d.gpu_mode = GPU_MODES[gpu]
        if gpu_share is not None:
            d.gpu_share = gpu_share.handle
        d.network_rate_hz = float(network_rate_hz)
        d.body_contact = contact_mode(body_contact)
        if body_contact_offset_m is not None:
            d.body_contact_offset_m = float(body_contact_offset_m)
        self.handle = _Handle()
        _check(lib, lib.plCreateInstance(context.handle, C.byref(d), C.byref(self.handle)), "plCreateInstance")
        self.vertex_count = asset.info["vertex_count"]
        self.joint_count = asset.info["joint_count"]
        self.last_result = 0

    def step(self, rotations, root_translation, root_rotation, dt_s):
        rot = _f32(rotations, (-1, 4))
        t = np.asarray(root_translation, np.float32).reshape(3)
        q = np.asarray(root_rotation, np.float32).reshape(4)
        frame = _FrameInput(rot.ctypes.data, rot.shape[0], 16, _Vec3(*map(float, t)), _Quat(*map(float, q)),
                            float(dt_s))
        positions = np.empty((self.vertex_count, 3), np.float32)
        normals = np.empty((self.vertex_count, 3), np.float32)
        out = _StepOutput(positions.ctypes.data, 12, normals.ctypes.data, 12, self.vertex_count)
        self.last_result = _check(self.lib, self.lib.plInstance_Step(self.handle, C.byref(frame), C.byref(out)),
                                  "plInstance_Step")
        return positions, normals

    def _get(self, fn, count, shape=None):
        out = np.empty(count, np.float32)
        _check(self.lib, getattr(self.lib, fn)(self.handle, out.ctypes.data, count if shape is None else shape),
               fn)
        return out

    @property
    def latent(self):
        return self._get("plInstance_GetLatent", self.asset.info["latent_count"])

    @property
    def blend_weights(self):
        return self._get("plInstance_GetBlendWeights", self.asset.info["blend_count"])

    @property
    def skin_matrices(self):
        J = self.joint_count
        return self._get("plInstance_GetSkinMatrices", J * 12, J).reshape(J, 3, 4)

    def rest_pose(self):
        """The rest pose for the instance's current β (plInstance_GetRestPose), see _rest_pose."""
        return _rest_pose(self.lib, "plInstance_GetRestPose", self.handle, self.joint_count)

    def reset(self):
        _check(self.lib, self.lib.plInstance_Reset(self.handle), "plInstance_Reset")

    def set_network_rate(self, network_rate_hz):
        _check(self.lib, self.lib.plInstance_SetNetworkRate(self.handle, float(network_rate_hz)),
               "plInstance_SetNetworkRate")

    def set_body_contact(self, enabled, offset_m):
        _check(self.lib, self.lib.plInstance_SetBodyContact(self.handle, contact_mode(enabled), float(offset_m)),
               "plInstance_SetBodyContact")

    def set_shape(self, beta):
        b = _f32(beta, -1)
        return _check(self.lib, self.lib.plInstance_SetShape(self.handle, b.ctypes.data, b.size),
                      "plInstance_SetShape")

    def set_material(self, material):
        m = _f32(material, 4)
        return _check(self.lib, self.lib.plInstance_SetMaterial(self.handle, m.ctypes.data), "plInstance_SetMaterial")

    def close(self):
        if self.handle.index1 and self.context.handle.index1:
            _check(self.lib, self.lib.plDestroyInstance(self.handle), "plDestroyInstance")
        self.handle = _Handle()
