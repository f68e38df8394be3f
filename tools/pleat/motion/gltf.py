"""glTF 2.0 (.gltf, .glb) skeletal animation → `SourceMotion`, the same form the BVH reader gives (docs/motion.md,
"glTF / GLB"). Parsed with pygltflib; the buffers, accessors and keyframes are read and checked here.

What is read:
- the **skeleton**: the joints of a skin (`skins[k].joints`), their hierarchy from the nodes' `children`, and their
  rest pose, which is the nodes' own TRS (or `matrix`), not the inverse bind matrices. Nodes above the skeleton's
  root (an "Armature" node with a scale or a turn) are applied as a fixed transform, and so are non-joint nodes
  between two joints. A skin whose joints form several trees keeps the largest; with several skins, the one the
  animation drives most.
- one **animation**: `animation` = its name or index (default: the first). Its `rotation` channels drive the joints,
  its `translation` channel on the root joint the root path, and on another joint that joint's offset from its
  parent (an engine's pelvis moving under its root bone); scale and morph-weight channels, and channels on nodes
  outside the skeleton, are not read.
- **interpolation**: LINEAR (slerp for rotations, lerp for translations) and STEP; CUBICSPLINE keys are read as their
  values (the middle of each in-tangent, value, out-tangent triple) and interpolated linearly, so the tangents'
  overshoot between keys is not reproduced.
- **time**: from the earliest to the latest key of the animation, resampled to uniform frames at `fps`; by default
  the keys' own rate (1 / the median spacing of the key times) when it is at least 24 per second (a baked
  animation), else 30 fps. Before the first key and after the last a channel holds its end value.

The result follows the BVH convention: rest world rotations are identity, so a joint's local rotation is taken
relative to its rest world orientation: with W(j) the world rotation in the file and W⁰(j) the rest one,
G(j) = W(j)·W⁰(j)ᵀ, and the SourceMotion's local rotation is G(parent)ᵀ·G(j). Rest positions are the joints'
world rest positions (metres, +Y up, as glTF says; the root path is rescaled by leg length anyway).

Checks, structure before values: a GLB's header, length and chunk table, then the JSON; glTF version 2; no required
extensions (compressed or quantised data); every index in range (nodes, children, skins, accessors, buffer views,
buffers); a node has at most one parent and the hierarchy has no cycle; accessors of the expected type and
component type that fit inside their buffer view and buffer, no sparse accessors; then finite numbers, non-zero
quaternions, key times that do not decrease. A failure is a `MotionFileError` naming the file.
"""
import base64
import binascii
import json
import math
from pathlib import Path

import numpy as np

from pleat.motion.readers import (MAX_DURATION_S, MAX_FRAME_TIME_S, MAX_JOINTS, MIN_FRAME_TIME_S, QUAT_MIN_NORM,
                                  MotionFileError, _clip_name)
from pleat.glb import GLB_MAGIC, glb_chunks
from pleat.motion.retarget import SourceMotion
from pleat.rotations import matrix_to_quat, quat_normalize, quat_slerp, quat_to_matrix

MAX_NODES = 100_000
MAX_ACCESSOR_ELEMENTS = 50_000_000    # floats of one accessor (a 1 h take of 1000 channels at 60 fps is 2e8 / 4)
MIN_BAKED_FPS = 24.0                  # keys at least this dense are a baked animation: their rate is the clip's
DEFAULT_FPS = 30.0
# componentType → (numpy dtype, divisor of a normalized integer: glTF 2.0 §3.11, max(c / divisor, −1))
COMPONENTS = {5120: ("<i1", 127.0), 5121: ("<u1", 255.0), 5122: ("<i2", 32767.0), 5123: ("<u2", 65535.0),
              5125: ("<u4", None), 5126: ("<f4", None)}
WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}


def read_gltf(path, fps=None, animation=None):
    """A .gltf / .glb file → SourceMotion of one animation (`animation`: name or index; default the first)."""
    path = Path(path)
    doc, blob = _document(path)
    reader = _Reader(path, doc, blob)
    anim_index, anim = _pick_animation(path, doc, animation)
    channels = _channels(reader, anim_index, anim)
    skeleton = _skeleton(reader, {node for node, _ in channels})
    names, parents, rest_world, rest_rot, links, above, root_node = skeleton
    joint_of = {n: j for j, n in enumerate(rest_world["nodes"])}
    times = np.concatenate([ch.times for ch in channels.values()])
    start, end = float(times.min()), float(times.max())
    if end - start > MAX_DURATION_S:
        raise MotionFileError(path, f"animation {anim.name or anim_index!r} lasts {end - start:.0f} s; clips longer "
                                    f"than {MAX_DURATION_S:.0f} s are not supported: cut it")
    rate = _frame_rate(path, channels.values(), fps)
    count = int(math.floor((end - start) * rate + 1e-3)) + 1      # key times are float32
    t = start + np.arange(count) / rate
    T, S = count, len(names)
    # local rotations (quaternions x, y, z, w): the animated ones where a channel drives the joint, else the rest's
    q = np.broadcast_to(rest_world["local_quat"], (T, S, 4)).copy()
    root_local = np.broadcast_to(rest_world["root_translation"], (T, 3)).copy()
    animated = [False] * S
    moved = {}                          # joint → its animated local translation [T, 3] (joints below the root)
    for (node, what), ch in channels.items():
        j = joint_of.get(node)
        if j is None:
            continue                    # a node outside the skeleton (a prop, the armature object): not read
        if what == "rotation":
            q[:, j] = ch.sample(t)
            animated[j] = True
        elif node == root_node:
            root_local = ch.sample(t)
        else:
            moved[j] = ch.sample(t)
    # world rotations in the file (rotation parts only: joint scales are taken as uniform), then relative to rest
    R = quat_to_matrix(q)
    W = np.empty_like(R)
    for j, p in enumerate(parents):
        W[:, j] = (above if p < 0 else W[:, p] @ links[j]) @ R[:, j]
    G = W @ np.swapaxes(rest_rot, -1, -2)[None]
    local = np.empty_like(G)
    for j, p in enumerate(parents):
        local[:, j] = G[:, j] if p < 0 else np.swapaxes(G[:, p], -1, -2) @ G[:, j]
    M = rest_world["above_matrix"]
    root = root_local @ M[:3, :3].T + M[:3, 3]
    # A joint below the root that moves (an engine's pelvis under its root bone): its offset from its parent, in the
    # frame the SourceMotion's parent rotation G(parent) turns (G·W⁰ is the file's world rotation), scaled like the
    # rest: W⁰(parent) · s(parent) · (link · t + link translation).
    translations = {}
    for j, tj in moved.items():
        p = parents[j]
        world_p, link = rest_world["world"][p], rest_world["link_matrices"][j]
        scale = float(np.linalg.norm(world_p[:3, 0]))
        v = tj @ link[:3, :3].T + link[:3, 3]
        translations[j] = scale * v @ rest_rot[p].T
    src = SourceMotion(name=_clip_name(path), source=f"glTF {path.name} animation {anim.name or anim_index!r}",
                       fps=float(rate), names=names, parents=np.array(parents), rest_positions=rest_world["positions"],
                       local_rotations=local, root_positions=root, joint_translations=translations)
    src.animated = animated
    return src


# ---- the file ------------------------------------------------------------------------------------------------------
def _document(path):
    """(pygltflib GLTF2, the GLB binary chunk or None), after checking the container and the JSON's top level."""
    try:
        from pygltflib import GLTF2
    except ImportError:
        raise MotionFileError(path, "reading glTF needs pygltflib (pip install pygltflib; scripts/setup.sh installs "
                                    "it)") from None
    data = path.read_bytes()
    if not data.strip():
        raise MotionFileError(path, "is empty")
    blob = None
    if path.suffix.lower() == ".glb" or data[:4] == GLB_MAGIC:
        text, blob = _glb_chunks(path, data)
    else:
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError:
            raise MotionFileError(path, "is not a text file (not UTF-8): not a glTF JSON file") from None
    try:
        top = json.loads(text)
    except json.JSONDecodeError as exc:
        raise MotionFileError(path, f"is not JSON ({exc.msg} at line {exc.lineno}, column {exc.colno})") from None
    if not isinstance(top, dict) or not isinstance(top.get("asset"), dict):
        raise MotionFileError(path, 'has no "asset" object: not a glTF file')
    version = str(top["asset"].get("version", ""))
    if not version.startswith("2."):
        raise MotionFileError(path, f"is glTF version {version or '(none)'!r}; only glTF 2.0 is read")
    required = top.get("extensionsRequired") or []
    if required:
        raise MotionFileError(path, f"needs the extensions {', '.join(map(str, required))} (compressed or quantised "
                                    "data): export without them")
    for key in ("nodes", "skins", "animations", "accessors", "bufferViews", "buffers"):
        if not isinstance(top.get(key, []), list):
            raise MotionFileError(path, f'"{key}" is not a list')
    try:
        doc = GLTF2.gltf_from_json(text)
    except Exception as exc:   # noqa: BLE001 - whatever the parser makes of a malformed document: one line
        raise MotionFileError(path, f"malformed glTF ({type(exc).__name__}: {exc})") from None
    return doc, blob


def _glb_chunks(path, data):
    """(JSON text, BIN chunk or None) of a GLB (pleat.glb checks the container)."""
    try:
        json_chunk, blob = glb_chunks(data)
    except ValueError as exc:
        raise MotionFileError(path, str(exc)) from None
    try:
        text = json_chunk.decode("utf-8")
    except UnicodeDecodeError:
        raise MotionFileError(path, "the GLB JSON chunk is not UTF-8 text") from None
    return text, blob


class _Reader:
    """Index-checked access to a document's nodes and accessors; each buffer decoded once."""

    def __init__(self, path, doc, blob):
        self.path, self.doc, self.blob = path, doc, blob
        self._buffers = {}

    def item(self, what, items, i, where):
        if isinstance(i, bool) or not isinstance(i, int) or not 0 <= i < len(items):
            raise MotionFileError(self.path, f"{where}: {what} index {i!r} is not in 0..{len(items) - 1}")
        return items[i]

    def buffer(self, i, where):
        if i in self._buffers:
            return self._buffers[i]
        buf = self.item("buffer", self.doc.buffers, i, where)
        uri = buf.uri
        if uri is None:
            if self.blob is None or i != 0:
                raise MotionFileError(self.path, f"buffer {i} has no uri and there is no GLB binary chunk for it")
            data = self.blob
        elif uri.startswith("data:"):
            head, _, payload = uri.partition(",")
            if not head.endswith(";base64"):
                raise MotionFileError(self.path, f"buffer {i}: only base64 data: URIs are read")
            try:
                data = base64.b64decode(payload, validate=True)
            except (binascii.Error, ValueError):
                raise MotionFileError(self.path, f"buffer {i}: its data: URI is not valid base64") from None
        else:
            file = self.path.parent / uri
            if not file.is_file():
                raise MotionFileError(self.path, f"buffer {i}: {uri!r} not found beside the .gltf file")
            data = file.read_bytes()
        size = buf.byteLength
        if not isinstance(size, int) or size < 0 or len(data) < size:
            raise MotionFileError(self.path, f"buffer {i} holds {len(data)} bytes; its byteLength says {size!r}")
        self._buffers[i] = data
        return data

    def accessor(self, i, types, where, floats_only=False):
        """Accessor i as float64 [count, width], checked against its view and buffer."""
        acc = self.item("accessor", self.doc.accessors, i, where)
        where = f"{where} (accessor {i})"
        if acc.sparse is not None:
            raise MotionFileError(self.path, f"{where} is sparse; sparse accessors are not read")
        if acc.type not in types:
            raise MotionFileError(self.path, f"{where} is {acc.type!r}, expected {' or '.join(types)}")
        comp = COMPONENTS.get(acc.componentType)
        if comp is None or (floats_only and acc.componentType != 5126) or \
                (acc.componentType != 5126 and not acc.normalized):
            raise MotionFileError(self.path, f"{where} has component type {acc.componentType!r}; expected float"
                                             + ("" if floats_only else " or a normalized integer"))
        width, count = WIDTH[acc.type], acc.count
        if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count * width <= MAX_ACCESSOR_ELEMENTS:
            raise MotionFileError(self.path, f"{where} has count {count!r}")
        dtype = np.dtype(comp[0])
        if acc.bufferView is None:                  # glTF: an accessor without a view is all zeros
            return np.zeros((count, width))
        view = self.item("buffer view", self.doc.bufferViews, acc.bufferView, where)
        data = self.buffer(view.buffer, f"buffer view {acc.bufferView}")
        v_off, v_len = view.byteOffset or 0, view.byteLength
        a_off = acc.byteOffset or 0
        elem = dtype.itemsize * width
        stride = view.byteStride or elem
        if not all(isinstance(x, int) and x >= 0 for x in (v_off, v_len, a_off, stride)) or stride < elem:
            raise MotionFileError(self.path, f"{where}: buffer view {acc.bufferView} has a bad offset, length or "
                                             "stride")
        if v_off + v_len > len(data):
            raise MotionFileError(self.path, f"buffer view {acc.bufferView} ({v_off}+{v_len} bytes) runs past its "
                                             f"buffer ({len(data)} bytes)")
        if a_off + stride * (count - 1) + elem > v_len:
            raise MotionFileError(self.path, f"{where}: {count} elements do not fit in buffer view "
                                             f"{acc.bufferView} ({v_len} bytes)")
        raw = np.ndarray((count, width), dtype, buffer=data, offset=v_off + a_off, strides=(stride, dtype.itemsize))
        out = raw.astype(np.float64)
        if comp[1] is not None:
            out = np.maximum(out / comp[1], -1.0)
        if not np.isfinite(out).all():
            k = int(np.argwhere(~np.isfinite(out))[0][0])
            raise MotionFileError(self.path, f"{where}: element {k} is not finite ({out[k].tolist()})")
        return out


# ---- animation -----------------------------------------------------------------------------------------------------
def _pick_animation(path, doc, animation):
    anims = doc.animations or []
    if not anims:
        raise MotionFileError(path, "has no animations")
    if animation is None:
        return 0, anims[0]
    names = [a.name for a in anims]
    if isinstance(animation, str) and animation in names:
        return names.index(animation), anims[names.index(animation)]
    try:
        k = int(animation)
    except (TypeError, ValueError):
        k = None
    if k is not None and 0 <= k < len(anims):
        return k, anims[k]
    shown = ", ".join(f"{i}: {n or '(no name)'}" for i, n in enumerate(names[:20]))
    raise MotionFileError(path, f"has no animation {animation!r} (it has {shown})")


class _Channel:
    def __init__(self, times, values, step, rotation):
        self.times, self.values, self.step, self.rotation = times, values, step, rotation

    def sample(self, t):
        """Values at times t: held before the first key and after the last; STEP holds each key, LINEAR (and
        CUBICSPLINE's values) slerp rotations and lerp translations."""
        k = len(self.times)
        # keys at or before t; key times are float32, so a frame time within their rounding counts as on the key
        after = np.searchsorted(self.times, t + 1e-6 + 2e-7 * np.abs(t), side="right")
        i0, i1 = np.clip(after - 1, 0, k - 1), np.clip(after, 0, k - 1)
        if self.step or k == 1:
            return self.values[i0]
        span = self.times[i1] - self.times[i0]
        a = np.clip((t - self.times[i0]) / np.where(span > 0, span, 1.0), 0.0, 1.0)
        if self.rotation:
            return quat_slerp(self.values[i0], self.values[i1], a)
        return self.values[i0] * (1 - a[:, None]) + self.values[i1] * a[:, None]


def _channels(reader, index, anim):
    """{(node, "rotation" | "translation"): _Channel} of the animation, checked."""
    path, where = reader.path, f"animation {anim.name or index!r}"
    out = {}
    for c, ch in enumerate(anim.channels or []):
        target = ch.target
        if target is None or target.path not in ("rotation", "translation", "scale", "weights"):
            raise MotionFileError(path, f"{where}, channel {c}: target path {getattr(target, 'path', None)!r} is "
                                        "not rotation, translation, scale or weights")
        if target.path not in ("rotation", "translation") or target.node is None:
            continue
        reader.item("node", reader.doc.nodes, target.node, f"{where}, channel {c}")
        sampler = reader.item("sampler", anim.samplers or [], ch.sampler, f"{where}, channel {c}")
        interp = sampler.interpolation or "LINEAR"
        if interp not in ("LINEAR", "STEP", "CUBICSPLINE"):
            raise MotionFileError(path, f"{where}, channel {c}: interpolation {interp!r} is not LINEAR, STEP or "
                                        "CUBICSPLINE")
        rotation = target.path == "rotation"
        times = reader.accessor(sampler.input, ("SCALAR",), f"{where}, channel {c} key times", floats_only=True)[:, 0]
        values = reader.accessor(sampler.output, ("VEC4",) if rotation else ("VEC3",),
                                 f"{where}, channel {c} values", floats_only=not rotation)
        want = 3 * len(times) if interp == "CUBICSPLINE" else len(times)
        if len(values) != want:
            raise MotionFileError(path, f"{where}, channel {c}: {len(values)} values for {len(times)} key times "
                                        f"({interp} needs {want})")
        if interp == "CUBICSPLINE":
            values = values[1::3]       # (in-tangent, value, out-tangent) per key: the values
        if np.any(np.diff(times) < 0):
            k = int(np.argmax(np.diff(times) < 0))
            raise MotionFileError(path, f"{where}, channel {c}: key time {times[k + 1]:g} s comes after "
                                        f"{times[k]:g} s: key times must not decrease")
        if rotation:
            small = np.linalg.norm(values, axis=1) < QUAT_MIN_NORM
            if small.any():
                raise MotionFileError(path, f"{where}, channel {c}: key {int(np.argmax(small))} is a zero "
                                            "quaternion")
            values = quat_normalize(values)
        out[(target.node, target.path)] = _Channel(times, values, interp == "STEP", rotation)
    if not any(what == "rotation" for _, what in out):
        raise MotionFileError(path, f"{where} has no rotation channel: nothing turns")
    return out


def _frame_rate(path, channels, fps):
    if fps is not None:
        return float(fps)
    gaps = np.concatenate([np.diff(ch.times) for ch in channels])
    gaps = gaps[gaps > 0]
    if not len(gaps):
        raise MotionFileError(path, "every key is at the same time: a clip needs at least two frames")
    rate = 1.0 / float(np.median(gaps))
    if abs(rate - round(rate)) < 1e-3 * rate:          # key times are float32: 29.99998 is 30
        rate = float(round(rate))
    if rate < MIN_BAKED_FPS:
        return DEFAULT_FPS
    if rate > 1.0 / MIN_FRAME_TIME_S or rate < 1.0 / MAX_FRAME_TIME_S:
        raise MotionFileError(path, f"keys at {rate:g} per second: outside {1 / MAX_FRAME_TIME_S:g}..."
                                    f"{1 / MIN_FRAME_TIME_S:g} fps")
    return rate


# ---- skeleton ------------------------------------------------------------------------------------------------------
def _node_matrix(path, node, i):
    """A node's local rest transform (4×4) and its rotation as a unit quaternion (x, y, z, w)."""
    if node.matrix is not None:
        m = np.asarray(node.matrix, np.float64)
        if m.shape != (16,) or not np.isfinite(m).all():
            raise MotionFileError(path, f"node {i}: matrix must be 16 finite numbers")
        M = m.reshape(4, 4).T                                  # glTF matrices are column-major
        return M, matrix_to_quat(_rotation_part(path, M[:3, :3], i))
    parts = {}
    for key, size, default in (("translation", 3, (0, 0, 0)), ("rotation", 4, (0, 0, 0, 1)), ("scale", 3, (1, 1, 1))):
        v = getattr(node, key)
        v = np.asarray(default if v is None else v, np.float64)
        if v.shape != (size,) or not np.isfinite(v).all():
            raise MotionFileError(path, f"node {i}: {key} must be {size} finite numbers")
        parts[key] = v
    if np.linalg.norm(parts["rotation"]) < QUAT_MIN_NORM:
        raise MotionFileError(path, f"node {i}: rotation is a zero quaternion")
    q = quat_normalize(parts["rotation"])
    M = np.eye(4)
    M[:3, :3] = quat_to_matrix(q) * parts["scale"][None, :]
    M[:3, 3] = parts["translation"]
    return M, q


def _rotation_part(path, A, i):
    """The rotation of a linear map (scale removed: the nearest rotation)."""
    U, s, Vt = np.linalg.svd(A)
    if s.min() < 1e-12:
        raise MotionFileError(path, f"node {i}: its transform has zero scale")
    R = U @ Vt
    if np.linalg.det(R) < 0:
        raise MotionFileError(path, f"node {i}: its transform mirrors (negative scale); not read")
    return R


def _skeleton(reader, driven):
    """The skin's joints as a tree: (names, parents, rest dict, rest world rotations [S, 3, 3], links [S, 3, 3]
    (the fixed turn from the joint parent's frame to the joint's parent node), the turn above the root [3, 3], the
    root node)."""
    path, doc = reader.path, reader.doc
    nodes = doc.nodes or []
    if len(nodes) > MAX_NODES:
        raise MotionFileError(path, f"has {len(nodes)} nodes; at most {MAX_NODES} are read")
    parent = {}
    for i, node in enumerate(nodes):
        for c in node.children or []:
            reader.item("node", nodes, c, f"node {i} children")
            if c in parent or c == i:
                raise MotionFileError(path, f"node {c} has two parents (nodes {parent.get(c, i)} and {i})")
            parent[c] = i
    for i in range(len(nodes)):          # a cycle never reaches a root
        k, steps = i, 0
        while k in parent:
            k, steps = parent[k], steps + 1
            if steps > len(nodes):
                raise MotionFileError(path, f"node {i}'s parents form a cycle")
    skins = doc.skins or []
    if not skins:
        raise MotionFileError(path, "has no skin: a glTF motion needs a skinned skeleton (skins[].joints)")
    for s, skin in enumerate(skins):
        for j in skin.joints or []:
            reader.item("node", nodes, j, f"skin {s} joints")
    skin_index = max(range(len(skins)), key=lambda s: (len(driven & set(skins[s].joints or [])), -s))
    joints = list(dict.fromkeys(skins[skin_index].joints or []))
    if not joints:
        raise MotionFileError(path, f"skin {skin_index} has no joints")
    if len(joints) > MAX_JOINTS:
        raise MotionFileError(path, f"skin {skin_index} has {len(joints)} joints; at most {MAX_JOINTS} are read")
    jset = set(joints)

    def joint_parent(n):
        k = parent.get(n)
        while k is not None and k not in jset:
            k = parent.get(k)
        return k
    jparent = {n: joint_parent(n) for n in joints}
    kids = {}
    for n in joints:                      # children in the order the nodes list them (deterministic)
        kids.setdefault(jparent[n], []).append(n)
    for k in kids.values():
        k.sort()

    def subtree(n):
        order, stack = [], [n]
        while stack:
            m = stack.pop()
            order.append(m)
            stack.extend(reversed(kids.get(m, [])))
        return order
    root = max(kids[None], key=lambda r: (len(subtree(r)), -r))
    order = subtree(root)
    idx = {n: j for j, n in enumerate(order)}
    names = [nodes[n].name or f"node{n}" for n in order]
    seen = set()
    for n in names:
        if n in seen:
            raise MotionFileError(path, f"joint name {n!r} appears twice")
        seen.add(n)
    parents = [-1 if jparent[n] is None or n == root else idx[jparent[n]] for n in order]
    local = {}
    for n in set(order) | {k for n in order for k in _chain(parent, n)}:
        local[n] = _node_matrix(path, nodes[n], n)

    def product(chain):
        M = np.eye(4)
        for k in chain:
            M = M @ local[k][0]
        return M
    above_m = product(list(reversed(_chain(parent, root))))      # every node above the root, outermost first
    S = len(order)
    world = np.empty((S, 4, 4))
    links = np.empty((S, 3, 3))
    link_matrices = np.empty((S, 4, 4))
    for j, n in enumerate(order):
        if parents[j] < 0:
            link = np.eye(4)
            world[j] = above_m @ local[n][0]
        else:
            between = []                                         # non-joint nodes from the joint parent down
            k = parent[n]
            while k != order[parents[j]]:
                between.append(k)
                k = parent[k]
            link = product(list(reversed(between)))
            world[j] = world[parents[j]] @ link @ local[n][0]
        links[j] = _rotation_part(path, link[:3, :3], n)
        link_matrices[j] = link
    rest_rot = np.stack([_rotation_part(path, world[j][:3, :3], n) for j, n in enumerate(order)])
    above = _rotation_part(path, above_m[:3, :3], root)
    rest = {"nodes": order, "positions": world[:, :3, 3].copy(), "local_quat": np.stack([local[n][1] for n in order]),
            "root_translation": local[root][0][:3, 3].copy(), "above_matrix": above_m, "world": world,
            "link_matrices": link_matrices}
    return names, parents, rest, rest_rot, links, above, root


def _chain(parent, n):
    """The nodes above n, nearest first."""
    out = []
    while n in parent:
        n = parent[n]
        out.append(n)
    return out
