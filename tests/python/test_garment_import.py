"""`pleat-garment import` (docs/garments.md): meshes generated here are exported as OBJ (in cm, Z up), glTF with a
.bin, GLB and glTF with a data URI and UV-seam-split vertices, imported, and compared with the garment they came
from: same vertices in the same order, same faces, the same diffused skin weights and shape blend shapes, the
generator's pins. A garment pushed into the body is fitted back out; faces turned inward are turned back; pins come
from the heuristics, a file or an OBJ group; bad meshes are one error line. ~20 s."""
import base64
import json
import struct
import subprocess
import sys

import numpy as np
import pytest

from pleat.garment import Garment, make_garment
from pleat.garment import mesh as M
from pleat.garment.generate import diffuse_from_body
from pleat.garment.importer import build_import_parser, import_garment, penetration
from pleat.garment.meshio import (MeshFileError, from_pleat_axes, read_gltf, read_mesh, read_obj, to_pleat_axes,
                                  write_gltf, write_obj)

N_TEST = 500


@pytest.fixture(scope="module")
def shirt(body):
    return make_garment("tshirt", vertices=N_TEST, body=body)


@pytest.fixture(scope="module")
def pants(body):
    return make_garment("pants", vertices=N_TEST, body=body)


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "pleat.garment.cli", *map(str, args)], capture_output=True,
                          text=True, timeout=300)


def test_axes_and_units_round_trip():
    p = np.array([[0.1, 1.2, -0.3], [-0.5, 0.0, 2.0]])
    for up in ("y", "z"):
        for units in ("m", "cm", "mm", "in", "0.5"):
            assert np.allclose(to_pleat_axes(from_pleat_axes(p, up, units), up, units), p)
    # Z up, facing -Y (Blender, 3ds Max) → Y up, facing +Z
    assert np.allclose(to_pleat_axes([[0.0, -1.0, 2.0]], "z", "cm"), [[0.0, 0.02, 0.01]])


def test_obj_reader_polygons_groups_relative_indices_and_comments(tmp_path):
    path = tmp_path / "quad.obj"
    path.write_text("# a quad and a triangle\nmtllib x.mtl\no panel\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0 1.0\n"
                    "vt 0 0\nvn 0 0 1\ng front\nf 1/1/1 2/1/1 3/1/1 4/1/1\ng back\nv 0 0 1\nf -1 -4 -5\n")
    mesh = read_obj(path)
    assert mesh.vertices.shape == (5, 3)
    assert mesh.faces.tolist() == [[0, 1, 2], [0, 2, 3], [4, 1, 0]]
    assert {k: v.tolist() for k, v in mesh.groups.items()} == {"front": [0, 1], "back": [2]}


@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
def test_gltf_writer_and_reader_round_trip(tmp_path, shirt, suffix):
    path = write_gltf(tmp_path / f"shirt{suffix}", shirt.template, shirt.faces)
    mesh = read_mesh(path)
    assert mesh.source == ("GLB" if suffix == ".glb" else "glTF")
    assert np.array_equal(mesh.vertices, shirt.template.astype(np.float64))
    assert np.array_equal(mesh.faces, shirt.faces)
    if suffix == ".gltf":
        assert (tmp_path / "shirt.bin").is_file()


def _seam_split_gltf(path, v, f, translation):
    """A glTF with a data URI, uint16 indices, interleaved (strided) positions, a node translation, a parent node,
    and every vertex of the first 40 faces duplicated (what exporters do at UV seams)."""
    v = np.asarray(v, np.float32)
    f = np.asarray(f, np.int64).copy()
    dup = np.unique(f[:40])
    extra = {int(k): len(v) + i for i, k in enumerate(dup)}
    v2 = np.concatenate([v, v[dup]])
    f[:40] = np.vectorize(extra.get)(f[:40])
    inter = np.zeros((len(v2), 5), np.float32)          # position + 2 floats of something else (UV): stride 20
    inter[:, :3] = v2 - np.asarray(translation, np.float32)
    pos_bytes = inter.tobytes()
    idx = f.astype(np.uint16).tobytes()
    blob = pos_bytes + idx
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
           "nodes": [{"name": "root", "children": [1]}, {"name": "shirt", "mesh": 0, "translation": list(translation)}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
           "buffers": [{"byteLength": len(blob),
                        "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
           "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(pos_bytes), "byteStride": 20},
                           {"buffer": 0, "byteOffset": len(pos_bytes), "byteLength": len(idx)}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": len(v2), "type": "VEC3"},
                         {"bufferView": 1, "componentType": 5123, "count": f.size, "type": "SCALAR"}]}
    path.write_text(json.dumps(doc))
    return len(dup)


def test_obj_and_gltf_imports_equal_the_generated_garment(tmp_path, body, shirt):
    """Export the generated t-shirt as OBJ (cm, Z up), GLB and a seam-split glTF; each import gives the garment back:
    same vertices in the same order, faces, and the skin weights and shape blend shapes make_garment diffused."""
    write_obj(tmp_path / "shirt_cm.obj", from_pleat_axes(shirt.template, "z", "cm"), shirt.faces)
    write_gltf(tmp_path / "shirt.glb", shirt.template, shirt.faces)
    split = _seam_split_gltf(tmp_path / "seams.gltf", shirt.template, shirt.faces, [0.0, 0.5, 0.0])
    cases = [("shirt_cm.obj", dict(units="cm", up="z")), ("shirt.glb", {}), ("seams.gltf", {})]
    si, sw, sd = diffuse_from_body(shirt.template.astype(np.float64), shirt.faces.astype(np.int64), body)
    for name, kw in cases:
        g, report, vmap, _ = import_garment(tmp_path / name, body, **kw)
        assert g.num_vertices == shirt.num_vertices, name
        assert np.allclose(g.template, shirt.template, atol=2e-6), name
        assert np.array_equal(g.faces, shirt.faces), name
        assert np.array_equal(g.skin_indices, si) and np.allclose(g.skin_weights, sw, atol=1e-5), name
        assert np.allclose(g.shape_blend, sd, atol=1e-5), name
        assert len(g.pinned) == 0 and not report["flipped"] and report["penetration_before"]["inside"] == 0
    assert report["welded"] == split and not report["order_kept"]            # the seams were welded back
    assert np.array_equal(vmap[:shirt.num_vertices], np.arange(shirt.num_vertices))


def test_pants_get_the_generators_waistband_pins(tmp_path, body, pants):
    write_obj(tmp_path / "pants.obj", pants.template, pants.faces)
    g, report, _, _ = import_garment(tmp_path / "pants.obj", body)
    assert np.array_equal(np.sort(g.pinned), np.sort(pants.pinned)) and len(g.pinned) > 10
    assert report["pins"].startswith("waistband")
    g, _, _, _ = import_garment(tmp_path / "pants.obj", body, pins="none")
    assert len(g.pinned) == 0


def test_collar_pins_pin_file_and_group(tmp_path, body, shirt):
    f = shirt.faces
    J = body.joints()
    neck = J[list(body.joint_names).index("neck")]
    loops = M.boundary_loops(f)
    collar = min(loops, key=lambda L: np.linalg.norm(shirt.template[L].mean(0) - neck))
    write_obj(tmp_path / "shirt.obj", shirt.template, f, groups={"body": np.arange(10, len(f)),
                                                                "tape": np.arange(10)})
    g, _, _, _ = import_garment(tmp_path / "shirt.obj", body, pins="collar")
    assert np.array_equal(np.sort(g.pinned), np.sort(collar))
    (tmp_path / "pins.txt").write_text("# pinned\n3, 5\n7\n")
    g, _, _, _ = import_garment(tmp_path / "shirt.obj", body, pins=str(tmp_path / "pins.txt"))
    assert g.pinned.tolist() == [3, 5, 7]
    (tmp_path / "pins.json").write_text(json.dumps({"pins": [9, 2]}))
    g, _, _, _ = import_garment(tmp_path / "shirt.obj", body, pins=str(tmp_path / "pins.json"))
    assert g.pinned.tolist() == [2, 9]
    g, _, _, _ = import_garment(tmp_path / "shirt.obj", body, pin_group="tape")
    assert g.pinned.tolist() == np.unique(f[:10]).tolist()


def test_fit_pushes_a_tight_garment_out_and_inward_faces_are_turned(tmp_path, body, shirt):
    from pleat.body.model import BodyCollider
    x = shirt.template - 0.014 * M.vertex_normals(shirt.template.astype(np.float64), shirt.faces)
    write_obj(tmp_path / "tight.obj", x, shirt.faces[:, [0, 2, 1]])          # inside the body and inside out
    g, report, _, _ = import_garment(tmp_path / "tight.obj", body, fit_mm=6.0)
    assert report["flipped"] and np.array_equal(g.faces, shirt.faces)
    assert report["penetration_before"]["inside"] > 0.5 * shirt.num_vertices
    assert report["penetration_after"]["inside"] == 0
    inside, close, _ = penetration(BodyCollider(body.v_template, body.faces), g.template)
    assert inside == 0 and close == 0                                          # ≥ 4 mm out everywhere
    moved = np.linalg.norm(g.template - x, axis=1)
    assert moved.max() < 0.03                                                  # pushed out, not blown up
    A = M.adjacency(g.faces, g.num_vertices)
    P = A.multiply(1.0 / np.asarray(A.sum(1))).tocsr()

    def bumps(y):                                                             # distance from the neighbours' mean
        y = np.asarray(y, np.float64)
        return np.linalg.norm(y - P @ y, axis=1).max()
    assert bumps(g.template) < bumps(shirt.template) + 0.003                  # the push is spread: no spikes


def test_cli_prints_the_report_and_writes_the_mesh_to_simulate(tmp_path, shirt):
    write_obj(tmp_path / "shirt_cm.obj", from_pleat_axes(shirt.template, "z", "cm"), shirt.faces)
    run = _cli("import", tmp_path / "shirt_cm.obj", "--units", "cm", "--up", "z", "--fit", "--out",
               tmp_path / "g.npz", "--write-obj", tmp_path / "sim.obj", "--json", tmp_path / "r.json")
    assert run.returncode == 0, run.stderr
    out = run.stdout
    for words in (f"{shirt.num_vertices} vertices", "penetration before fit: 0 vertices inside",
                  "penetration after fit: 0 vertices inside", "skin weights:", "pins: none", "wrote"):
        assert words in out, (words, out)
    g = Garment.load(tmp_path / "g.npz")
    sim = read_obj(tmp_path / "sim.obj")
    assert np.allclose(to_pleat_axes(sim.vertices, "z", "cm"), g.template, atol=1e-6)
    assert json.loads((tmp_path / "r.json").read_text())["vertices"] == g.num_vertices


def test_import_and_scene_parsers_follow_the_cli_conventions():
    from pleat.garment.scene import build_scene_parser
    for p, out in ((build_import_parser(), "output file"), (build_scene_parser(), "output folder")):
        flags = {f: a for a in p._actions for f in a.option_strings}
        assert flags["--out"].help.startswith(out) and "body npz" in flags["--body"].help
        assert flags["--quiet"].dest == "quiet" and flags["--no-progress"].dest == "quiet"
        assert all(a.help for a in p._actions)


def _bad_files(tmp_path, shirt):
    v, f = shirt.template, shirt.faces
    (tmp_path / "empty.obj").write_text("# nothing\n")
    (tmp_path / "words.obj").write_text("v 0 0 zero\n")
    (tmp_path / "range.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n")
    (tmp_path / "nan.obj").write_text("v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    write_obj(tmp_path / "cm_as_m.obj", v * 100.0, f)
    write_obj(tmp_path / "far.obj", v + [0.0, 0.0, 1.0], f)
    nm = np.concatenate([f, f[:1][:, [0, 2, 1]]])                              # a face twice, once reversed
    write_obj(tmp_path / "nonmanifold.obj", v, nm)
    glb = bytearray(write_gltf(tmp_path / "ok.glb", v, f).read_bytes())
    (tmp_path / "magic.glb").write_bytes(b"glTX" + bytes(glb[4:]))
    (tmp_path / "short.glb").write_bytes(bytes(glb[:-40]))
    doc = json.loads(write_gltf(tmp_path / "d.gltf", v, f).read_text())
    doc["extensionsRequired"] = ["KHR_draco_mesh_compression"]
    (tmp_path / "draco.gltf").write_text(json.dumps(doc))
    doc = json.loads((tmp_path / "d.gltf").read_text())
    doc["accessors"][1]["count"] += 30
    (tmp_path / "overrun.gltf").write_text(json.dumps(doc))
    doc = json.loads((tmp_path / "d.gltf").read_text())
    doc["buffers"][0]["uri"] = "missing.bin"
    (tmp_path / "nobin.gltf").write_text(json.dumps(doc))
    (tmp_path / "mesh.ply").write_text("ply\n")
    return {"empty.obj": "no vertices", "words.obj": "not numbers", "range.obj": "not defined yet",
            "nan.obj": "not finite", "cm_as_m.obj": "wrong --units", "far.obj": "from the body",
            "nonmanifold.obj": "not an oriented manifold", "magic.glb": "not a GLB file",
            "short.glb": "truncated", "draco.gltf": "KHR_draco_mesh_compression", "overrun.gltf": "bufferView",
            "nobin.gltf": "not found beside", "mesh.ply": "unknown mesh format", "absent.obj": "no such mesh file"}


def test_bad_meshes_are_one_error_line(tmp_path, shirt):
    for name, words in _bad_files(tmp_path, shirt).items():
        run = _cli("import", tmp_path / name, "--out", tmp_path / "x.npz")
        lines = run.stderr.strip().splitlines()
        assert run.returncode == 1 and len(lines) == 1, (name, run.stderr)
        assert lines[0].startswith("pleat-garment: error: ") and words in lines[0], (name, lines[0])
        assert not (tmp_path / "x.npz").exists()


def test_gltf_byte_ranges_are_checked_before_reading(tmp_path, shirt):
    path = write_gltf(tmp_path / "s.gltf", shirt.template, shirt.faces)
    doc = json.loads(path.read_text())
    doc["bufferViews"][0]["byteLength"] = 10 ** 9
    path.write_text(json.dumps(doc))
    with pytest.raises(MeshFileError, match="outside its buffer"):
        read_gltf(path)
    glb = bytearray(write_gltf(tmp_path / "s.glb", shirt.template, shirt.faces).read_bytes())
    struct.pack_into("<I", glb, 12, 10 ** 8)                       # the JSON chunk claims more than the file holds
    (tmp_path / "s.glb").write_bytes(bytes(glb))
    with pytest.raises(MeshFileError, match="chunk"):
        read_gltf(tmp_path / "s.glb")


def test_mutated_gltf_and_obj_files_never_crash_the_readers(tmp_path, shirt):
    """300 mutations of a small GLB (digits in its JSON changed — counts, offsets, indices, types — and random bytes
    anywhere) and of an OBJ: each read either gives a mesh with valid indices or raises MeshFileError."""
    rng = np.random.default_rng(7)
    v, f = M.compact(shirt.template, shirt.faces[:40].astype(np.int64))
    glb = write_gltf(tmp_path / "s.glb", v, f).read_bytes()
    json_len = struct.unpack_from("<I", glb, 12)[0]
    digits = [i for i in range(20, 20 + json_len) if chr(glb[i]).isdigit()]
    obj = write_obj(tmp_path / "s.obj", v, f).read_bytes()
    for k in range(300):
        if k % 3 == 2:
            data, path = bytearray(obj), tmp_path / "m.obj"
            for i in rng.integers(0, len(data), 3):
                data[i] = int(rng.choice(list(b"0123456789 -/\nfv.")))
        else:
            data, path = bytearray(glb), tmp_path / "m.glb"
            if k % 3 == 0:
                for i in rng.choice(digits, 2):
                    data[i] = ord(str(rng.integers(0, 10)))
            else:
                for i in rng.integers(0, len(data), 4):
                    data[i] = int(rng.integers(0, 256))
        path.write_bytes(bytes(data))
        try:
            mesh = read_mesh(path)
        except MeshFileError:
            continue
        assert mesh.faces.min() >= 0 and mesh.faces.max() < len(mesh.vertices) and np.isfinite(mesh.vertices).all()
