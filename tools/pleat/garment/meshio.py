"""Triangle meshes from DCC tools: a Wavefront OBJ reader and writer and a minimal glTF 2.0 reader and writer
(positions and triangle indices only), numpy alone (docs/garments.md, "Your own garment").

    mesh = read_mesh("shirt.obj")                  # or .gltf (JSON + .bin or data: URIs) or .glb
    x = to_pleat_axes(mesh.vertices, up="z", units="cm")

Reading is parse, then check: every reader checks structure (signatures, sizes, counts, byte ranges) before it
reads a value, then meaning (finite coordinates, index ranges, at least one triangle), and raises
`MeshFileError(path, what is wrong)` — one line in the CLIs (pleat.cli). Polygons are fan-triangulated. glTF
meshes are placed by their nodes' transforms (the default scene, or every mesh when there is none);
compressed or quantised glTF (extensionsRequired) is refused with a message saying so.

Axes: Pleat is metres, +Y up, the body facing +Z (docs/inputs.md). A Z-up tool (Blender, 3ds Max) has the
character facing −Y; `to_pleat_axes(x, up="z")` maps (x, y, z) ↦ (x, z, −y), which takes that to Pleat's frame.
"""
import base64
import json
import math
import struct
import urllib.parse
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pleat.cli import InputError, read_by_suffix
from pleat.glb import GLB_BIN, GLB_JSON, GLB_MAGIC, glb_chunks

UNITS_M = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254}
MAX_VERTICES = 2_000_000
MAX_ACCESSOR = 3 * 4 * MAX_VERTICES   # elements of one glTF accessor (indices of 4 triangles per vertex)
MAX_POLYGON = 256                 # vertices of one OBJ face: more is a malformed file, not a garment


class MeshFileError(InputError):
    """A mesh file that cannot be read as a triangle mesh, and why (one line)."""


@dataclass
class Mesh:
    vertices: np.ndarray                                   # [N, 3] float64, in the file's units and axes
    faces: np.ndarray                                      # [F, 3] int64
    groups: dict = field(default_factory=dict)             # group / object / mesh name → face indices [k]
    source: str = ""                                       # "OBJ" | "glTF" | "GLB"
    notes: list = field(default_factory=list)              # what reading did that the user should know


# ---- axes and units ------------------------------------------------------------------------------------------------
def unit_scale(units):
    """Metres per file unit: m, cm, mm, in, or a positive number."""
    if isinstance(units, str) and units in UNITS_M:
        return UNITS_M[units]
    try:
        value = float(units)
    except (TypeError, ValueError):
        raise ValueError(f"units {units!r}: use one of {', '.join(UNITS_M)} or metres per unit") from None
    if not (value > 0 and math.isfinite(value)):
        raise ValueError(f"units {units!r}: metres per unit must be a positive number")
    return value


def _check_up(up):
    if up not in ("y", "z"):
        raise ValueError(f"up axis {up!r}: use y or z")


def to_pleat_axes(points, up="y", units="m"):
    """File coordinates [..., 3] → Pleat's (metres, +Y up, facing +Z)."""
    _check_up(up)
    p = np.asarray(points, np.float64) * unit_scale(units)
    if up == "z":
        p = np.stack([p[..., 0], p[..., 2], -p[..., 1]], axis=-1)
    return p


def from_pleat_axes(points, up="y", units="m"):
    """Inverse of to_pleat_axes: Pleat coordinates → the file's units and axes."""
    _check_up(up)
    p = np.asarray(points, np.float64)
    if up == "z":
        p = np.stack([p[..., 0], -p[..., 2], p[..., 1]], axis=-1)
    return p / unit_scale(units)


# ---- checks shared by the readers ----------------------------------------------------------------------------------
def _check_mesh(path, v, f, what):
    if len(v) == 0:
        raise MeshFileError(path, f"{what} has no vertices")
    if len(f) == 0:
        raise MeshFileError(path, f"{what} has no triangles (only points or lines?)")
    if not np.isfinite(v).all():
        k = int(np.argwhere(~np.isfinite(v))[0, 0])
        raise MeshFileError(path, f"vertex {k} is not finite ({v[k].tolist()})")
    if f.min() < 0 or f.max() >= len(v):
        bad = int(f.max() if f.max() >= len(v) else f.min())
        raise MeshFileError(path, f"a triangle uses vertex {bad}, but there are {len(v)} vertices")


def read_mesh(path):
    """A triangle mesh from .obj, .gltf or .glb (by suffix)."""
    return read_by_suffix(path, {".obj": read_obj, ".gltf": read_gltf, ".glb": read_gltf}, "mesh", MeshFileError)


# ---- OBJ -----------------------------------------------------------------------------------------------------------
def _obj_index(path, lineno, word, count):
    head = word.split("/", 1)[0]
    try:
        i = int(head)
    except ValueError:
        raise MeshFileError(path, f"line {lineno}: face index {word[:40]!r} is not an integer") from None
    if i == 0:
        raise MeshFileError(path, f"line {lineno}: face index 0 (OBJ indices start at 1)")
    j = i - 1 if i > 0 else count + i
    if not 0 <= j < count:
        raise MeshFileError(path, f"line {lineno}: face index {i} names a vertex that is not defined yet "
                                  f"({count} so far)")
    return j


def read_obj(path):
    """Vertices, triangles and groups (`g`/`o` names → their faces) of a Wavefront OBJ file. Texture and normal
    indices, materials, lines and points are ignored; polygons are fan-triangulated; negative (relative) indices
    are resolved. Vertex order is the file's: it is what a point cache of the same mesh follows."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="strict")
    except UnicodeDecodeError:
        raise MeshFileError(path, "is not a text file (not UTF-8): not an OBJ file") from None
    verts, faces, face_group = [], [], []
    group_names, current = [], None
    pending = ""
    for lineno, line in enumerate(text.splitlines(), 1):
        if line.endswith("\\"):                 # line continuation
            pending += line[:-1] + " "
            continue
        line, pending = pending + line, ""
        parts = line.split("#", 1)[0].split()
        if not parts:
            continue
        key = parts[0]
        if key == "v":
            if len(parts) < 4:
                raise MeshFileError(path, f"line {lineno}: a vertex needs x y z, found {' '.join(parts[1:])[:40]!r}")
            try:
                verts.append((float(parts[1]), float(parts[2]), float(parts[3])))
            except ValueError:
                raise MeshFileError(path, f"line {lineno}: vertex coordinates {' '.join(parts[1:4])[:60]!r} are "
                                          "not numbers") from None
            if len(verts) > MAX_VERTICES:
                raise MeshFileError(path, f"has more than {MAX_VERTICES} vertices")
        elif key == "f":
            if len(parts) < 4:
                raise MeshFileError(path, f"line {lineno}: a face needs at least 3 vertices")
            if len(parts) - 1 > MAX_POLYGON:
                raise MeshFileError(path, f"line {lineno}: a face with {len(parts) - 1} vertices")
            idx = [_obj_index(path, lineno, w, len(verts)) for w in parts[1:]]
            for k in range(1, len(idx) - 1):
                faces.append((idx[0], idx[k], idx[k + 1]))
                face_group.append(current)
        elif key in ("g", "o"):
            current = " ".join(parts[1:]) or None
            if current is not None and current not in group_names:
                group_names.append(current)
        # vt, vn, vp, l, p, s, usemtl, mtllib, curves: not part of the garment's shape
    v = np.array(verts, np.float64).reshape(-1, 3)
    f = np.array(faces, np.int64).reshape(-1, 3)
    _check_mesh(path, v, f, "the OBJ file")
    groups = {}
    fg = np.array([g if g is not None else "" for g in face_group], dtype=object)
    for name in group_names:
        hit = np.nonzero(fg == name)[0]
        if len(hit):
            groups[name] = hit
    return Mesh(v, f, groups, "OBJ")


def write_obj(path, vertices, faces, groups=None, header=None):
    """An OBJ file (1-based indices; `groups` {name: face indices} become `g` blocks), written atomically."""
    from pleat.fileio import write_text
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64)
    lines = [f"# {line}" for line in (header or "").splitlines()]
    lines += [f"v {p[0]:.9g} {p[1]:.9g} {p[2]:.9g}" for p in v]
    order = [(None, np.arange(len(f)))] if not groups else list(groups.items())
    written = np.zeros(len(f), bool)
    for name, idx in order:
        if name is not None:
            lines.append(f"g {name}")
        for a, b, c in f[idx] + 1:
            lines.append(f"f {a} {b} {c}")
        written[idx] = True
    if groups and not written.all():
        lines.append("g ungrouped")
        lines += [f"f {a} {b} {c}" for a, b, c in f[~written] + 1]
    write_text(path, "\n".join(lines) + "\n")
    return Path(path)


# ---- glTF 2.0 ------------------------------------------------------------------------------------------------------
_COMPONENT = {5120: ("i1", 1), 5121: ("u1", 1), 5122: ("<i2", 2), 5123: ("<u2", 2), 5125: ("<u4", 4),
              5126: ("<f4", 4)}
_TYPE_SIZE = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
_MODES = {0: "points", 1: "lines", 2: "line loop", 3: "line strip", 4: "triangles", 5: "triangle strip",
          6: "triangle fan"}


def _glb_chunks(path, data):
    """(JSON dict, BIN bytes or None) of a .glb file (pleat.glb checks the container)."""
    try:
        json_chunk, binary = glb_chunks(data)
    except ValueError as exc:
        raise MeshFileError(path, str(exc)) from None
    try:
        doc = json.loads(json_chunk.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise MeshFileError(path, f"GLB JSON chunk is not valid JSON ({exc})") from None
    return doc, binary


def _buffer(path, doc, i, glb_bin, cache):
    if i in cache:
        return cache[i]
    buffers = doc.get("buffers", [])
    if not isinstance(i, int) or not 0 <= i < len(buffers):
        raise MeshFileError(path, f"buffer {i} does not exist ({len(buffers)} buffers)")
    b = buffers[i]
    uri = b.get("uri")
    if uri is None:
        if glb_bin is None or i != 0:
            raise MeshFileError(path, f"buffer {i} has no uri and there is no GLB binary chunk for it")
        data = glb_bin
    elif uri.startswith("data:"):
        head, _, payload = uri.partition(",")
        if not head.endswith(";base64"):
            raise MeshFileError(path, f"buffer {i}: data URI is not base64")
        try:
            data = base64.b64decode(payload, validate=True)
        except ValueError:
            raise MeshFileError(path, f"buffer {i}: data URI is not valid base64") from None
    else:
        file = path.parent / urllib.parse.unquote(uri)
        if not file.is_file():
            raise MeshFileError(path, f"buffer {i}: {uri!r} not found beside the .gltf file")
        data = file.read_bytes()
    length = b.get("byteLength")
    if not isinstance(length, int) or length > len(data):
        raise MeshFileError(path, f"buffer {i}: byteLength {length} but {len(data)} bytes of data")
    cache[i] = data[:length]
    return cache[i]


def _accessor(path, doc, i, glb_bin, cache, want):
    """Accessor i as an array [count, components]; `want`: 'positions' or 'indices' (what is accepted)."""
    accessors = doc.get("accessors", [])
    if not isinstance(i, int) or not 0 <= i < len(accessors):
        raise MeshFileError(path, f"accessor {i} does not exist ({len(accessors)} accessors)")
    a = accessors[i]
    ctype, atype, count = a.get("componentType"), a.get("type"), a.get("count")
    if ctype not in _COMPONENT or atype not in _TYPE_SIZE or not isinstance(count, int) or count < 0:
        raise MeshFileError(path, f"accessor {i}: componentType {ctype}, type {atype}, count {count} are not valid "
                                  "glTF")
    if want == "positions" and (atype != "VEC3" or ctype != 5126):
        raise MeshFileError(path, f"accessor {i} (POSITION) is {atype} of componentType {ctype}; expected VEC3 "
                                  "float (5126): quantised positions are not read")
    if want == "indices" and (atype != "SCALAR" or ctype not in (5121, 5123, 5125)):
        raise MeshFileError(path, f"accessor {i} (indices) is {atype} of componentType {ctype}; expected SCALAR "
                                  "unsigned byte, short or int")
    if count > MAX_ACCESSOR:
        raise MeshFileError(path, f"accessor {i} has {count} elements (at most {MAX_ACCESSOR} are read)")
    if "sparse" in a:
        raise MeshFileError(path, f"accessor {i} is sparse, which this reader does not support (export without "
                                  "morph targets or sparse accessors)")
    dtype, size = _COMPONENT[ctype]
    ncomp = _TYPE_SIZE[atype]
    if "bufferView" not in a:                      # the spec: all zeros
        return np.zeros((count, ncomp), np.dtype(dtype))
    views = doc.get("bufferViews", [])
    vi = a["bufferView"]
    if not isinstance(vi, int) or not 0 <= vi < len(views):
        raise MeshFileError(path, f"accessor {i}: bufferView {vi} does not exist")
    view = views[vi]
    data = _buffer(path, doc, view.get("buffer"), glb_bin, cache)
    v_off, v_len = view.get("byteOffset", 0), view.get("byteLength")
    if not isinstance(v_off, int) or not isinstance(v_len, int) or v_off < 0 or v_len < 0 \
            or v_off + v_len > len(data):
        raise MeshFileError(path, f"bufferView {vi}: bytes {v_off}..{v_off}+{v_len} are outside its buffer "
                                  f"({len(data)} bytes)")
    elem = size * ncomp
    stride = view.get("byteStride") or elem
    a_off = a.get("byteOffset", 0)
    if not isinstance(stride, int) or stride < elem or not isinstance(a_off, int) or a_off < 0:
        raise MeshFileError(path, f"accessor {i}: byteStride {stride} / byteOffset {a_off} are not valid")
    need = a_off + (stride * (count - 1) + elem if count else 0)
    if need > v_len:
        raise MeshFileError(path, f"accessor {i}: {count} elements need {need} bytes, bufferView {vi} has {v_len}")
    if count == 0:
        return np.zeros((0, ncomp), np.dtype(dtype))
    raw = np.frombuffer(data, np.uint8, count=need - a_off, offset=v_off + a_off)
    rows = np.lib.stride_tricks.as_strided(raw, shape=(count, elem), strides=(stride, 1))
    return np.ascontiguousarray(rows).view(np.dtype(dtype)).reshape(count, ncomp)


def _node_matrix(path, node, k):
    if "matrix" in node:
        m = np.asarray(node["matrix"], np.float64)
        if m.shape != (16,):
            raise MeshFileError(path, f"node {k}: matrix must have 16 numbers")
        return m.reshape(4, 4).T                  # glTF stores column-major
    t = np.asarray(node.get("translation", [0, 0, 0]), np.float64)
    q = np.asarray(node.get("rotation", [0, 0, 0, 1]), np.float64)
    s = np.asarray(node.get("scale", [1, 1, 1]), np.float64)
    if t.shape != (3,) or q.shape != (4,) or s.shape != (3,):
        raise MeshFileError(path, f"node {k}: translation / rotation / scale have the wrong length")
    from pleat.rotations import quat_to_matrix
    n = np.linalg.norm(q)
    m = np.eye(4)
    m[:3, :3] = (quat_to_matrix(q / n) if n > 0 else np.eye(3)) * s[None, :]
    m[:3, 3] = t
    return m


def _triangles(path, idx, mode, where):
    if mode == 4:
        if len(idx) % 3:
            raise MeshFileError(path, f"{where}: {len(idx)} indices is not a multiple of 3")
        return idx.reshape(-1, 3)
    if mode == 5:                                  # strip: every other triangle reversed to keep the winding
        tri = np.stack([idx[:-2], idx[1:-1], idx[2:]], 1)
        tri[1::2] = tri[1::2][:, [1, 0, 2]]
        return tri
    return np.stack([np.full(len(idx) - 2, idx[0]), idx[1:-1], idx[2:]], 1)     # fan


def read_gltf(path):
    """Positions and triangles of every mesh of a glTF 2.0 file (.gltf with .bin files or data URIs, or .glb),
    placed by the default scene's node transforms; primitives of other modes (points, lines) are skipped."""
    path = Path(path)
    data = path.read_bytes()
    glb = data[:4] == GLB_MAGIC
    if glb:
        doc, glb_bin = _glb_chunks(path, data)
    else:
        if path.suffix.lower() == ".glb":
            raise MeshFileError(path, f"does not start with 'glTF' (found {data[:4]!r}): not a GLB file")
        try:
            doc = json.loads(data.decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise MeshFileError(path, f"is not glTF JSON ({type(exc).__name__}: {exc})") from None
        glb_bin = None
    try:
        return _read_gltf_doc(path, doc, glb_bin, "GLB" if glb else "glTF")
    except MeshFileError:
        raise
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as exc:
        raise MeshFileError(path, f"malformed glTF ({type(exc).__name__}: {exc})") from None


def _read_gltf_doc(path, doc, glb_bin, kind):
    if not isinstance(doc, dict) or not str(doc.get("asset", {}).get("version", "")).startswith("2"):
        raise MeshFileError(path, "is not glTF 2.0 (asset.version must be \"2.0\")")
    required = doc.get("extensionsRequired") or []
    if required:
        raise MeshFileError(path, f"needs the extension(s) {', '.join(map(str, required))}, which this reader does "
                                  "not support: export without mesh compression or quantisation")
    meshes, nodes = doc.get("meshes", []), doc.get("nodes", [])
    if not meshes:
        raise MeshFileError(path, "has no meshes")
    # (mesh index, world matrix, name) for each mesh instance of the default scene; every mesh once without scenes
    placed = []
    scenes = doc.get("scenes", [])
    if scenes:
        k = doc.get("scene", 0)
        if not isinstance(k, int) or not 0 <= k < len(scenes):
            raise MeshFileError(path, f"scene {k} does not exist ({len(scenes)} scenes)")
        scene = scenes[k]
        stack = [(k, np.eye(4)) for k in reversed(scene.get("nodes", []))]
        seen = 0
        while stack:
            k, parent = stack.pop()
            seen += 1
            if not isinstance(k, int) or not 0 <= k < len(nodes) or seen > 100_000:
                raise MeshFileError(path, f"node {k} does not exist, or the node graph has a cycle")
            world = parent @ _node_matrix(path, nodes[k], k)
            if "mesh" in nodes[k]:
                placed.append((nodes[k]["mesh"], world, nodes[k].get("name") or f"node{k}"))
            stack.extend((c, world) for c in reversed(nodes[k].get("children", [])))
    else:
        placed = [(m, np.eye(4), meshes[m].get("name") or f"mesh{m}") for m in range(len(meshes))]
    cache, verts, faces, groups, notes = {}, [], [], {}, []
    base, nface = 0, 0
    for m, world, name in placed:
        if not isinstance(m, int) or not 0 <= m < len(meshes):
            raise MeshFileError(path, f"mesh {m} does not exist ({len(meshes)} meshes)")
        for p_i, prim in enumerate(meshes[m].get("primitives", [])):
            where = f"mesh {m} primitive {p_i}"
            mode = prim.get("mode", 4)
            if mode not in (4, 5, 6):
                notes.append(f"{where}: {_MODES.get(mode, mode)} skipped")
                continue
            if "POSITION" not in prim.get("attributes", {}):
                raise MeshFileError(path, f"{where} has no POSITION attribute")
            pos = _accessor(path, doc, prim["attributes"]["POSITION"], glb_bin, cache, "positions").astype(np.float64)
            if "indices" in prim:
                idx = _accessor(path, doc, prim["indices"], glb_bin, cache, "indices").astype(np.int64).ravel()
            else:
                idx = np.arange(len(pos), dtype=np.int64)
            if len(idx) and idx.max() >= len(pos):
                raise MeshFileError(path, f"{where}: index {int(idx.max())} but only {len(pos)} positions")
            if len(idx) < 3:
                continue
            tri = _triangles(path, idx, mode, where)
            if not np.allclose(world, np.eye(4)):
                pos = pos @ world[:3, :3].T + world[:3, 3]
                if np.linalg.det(world[:3, :3]) < 0:         # a mirroring transform flips the winding
                    tri = tri[:, [0, 2, 1]]
            verts.append(pos)
            faces.append(tri + base)
            groups.setdefault(name, []).append(np.arange(nface, nface + len(tri)))
            base += len(pos)
            nface += len(tri)
            if base > MAX_VERTICES:
                raise MeshFileError(path, f"has more than {MAX_VERTICES} vertices")
    v = np.concatenate(verts) if verts else np.zeros((0, 3))
    f = np.concatenate(faces) if faces else np.zeros((0, 3), np.int64)
    _check_mesh(path, v, f, "the glTF file")
    return Mesh(v, f, {k: np.concatenate(g) for k, g in groups.items()}, kind, notes)


def write_gltf(path, vertices, faces, name="garment"):
    """A minimal glTF 2.0 file: one mesh, one node, float32 positions and uint32 indices. `.glb` → one binary file;
    `.gltf` → JSON with the buffer in a `.bin` file beside it. Written atomically."""
    from pleat.fileio import write_bytes, write_text
    path = Path(path)
    v = np.ascontiguousarray(vertices, np.float32)
    f = np.ascontiguousarray(faces, np.uint32)
    pos_bytes, idx_bytes = v.tobytes(), f.tobytes()
    blob = pos_bytes + idx_bytes
    doc = {
        "asset": {"version": "2.0", "generator": "pleat.garment.meshio"},
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "name": name}],
        "meshes": [{"name": name, "primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "mode": 4}]}],
        "buffers": [{"byteLength": len(blob)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(pos_bytes), "target": 34962},
                        {"buffer": 0, "byteOffset": len(pos_bytes), "byteLength": len(idx_bytes), "target": 34963}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": len(v), "type": "VEC3",
                       "min": v.min(0).tolist(), "max": v.max(0).tolist()},
                      {"bufferView": 1, "componentType": 5125, "count": int(f.size), "type": "SCALAR"}],
    }
    if path.suffix.lower() == ".glb":
        js = json.dumps(doc, separators=(",", ":")).encode()
        js += b" " * (-len(js) % 4)
        blob_p = blob + b"\0" * (-len(blob) % 4)
        out = struct.pack("<4sII", GLB_MAGIC, 2, 12 + 8 + len(js) + 8 + len(blob_p))
        out += struct.pack("<II", len(js), GLB_JSON) + js + struct.pack("<II", len(blob_p), GLB_BIN) + blob_p
        write_bytes(path, out)
    else:
        bin_path = path.with_suffix(".bin")
        doc["buffers"][0]["uri"] = urllib.parse.quote(bin_path.name)
        write_bytes(bin_path, blob)
        write_text(path, json.dumps(doc, indent=1))
    return path


def weld(vertices, faces, tolerance=0.0):
    """Merge vertices closer than `tolerance` (0: exactly equal positions, as glTF exporters split vertices at
    UV seams). Returns (vertices, faces, representative index per input vertex); the first vertex of a cluster
    keeps its place, so vertex order is kept where nothing was merged."""
    v = np.asarray(vertices, np.float64)
    if tolerance > 0:
        from scipy.sparse.csgraph import connected_components
        from scipy.spatial import cKDTree
        pairs = cKDTree(v).query_pairs(tolerance, output_type="ndarray")
        from scipy.sparse import coo_matrix
        g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(v), len(v)))
        _, label = connected_components(g, directed=False)
    else:
        _, label = np.unique(v, axis=0, return_inverse=True)
        label = label.ravel()
    first = np.full(label.max() + 1, len(v), np.int64)
    np.minimum.at(first, label, np.arange(len(v)))
    rep = first[label]                               # each vertex → the first vertex of its cluster
    keep = np.unique(rep)
    remap = np.full(len(v), -1, np.int64)
    remap[keep] = np.arange(len(keep))
    f = remap[rep[np.asarray(faces, np.int64)]]
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
    return v[keep], f, remap[rep]
