"""pleat-pack CLI and the ONNX export (run with onnxruntime against the numpy reference)."""
import json
import subprocess
import sys

import numpy as np
import pytest

from pleat import asset as pa
from pleat import pack
from pleat.reference.golden import random_weights
from pleat.reference.mlp import layers, mlp


@pytest.fixture(scope="module")
def weights():
    return random_weights(vertices=100, latent=8, blend=6, lp_hidden=(24, 16), dec_hidden=(12,), seed=11)


@pytest.fixture()
def weights_file(tmp_path, weights):
    path = tmp_path / "w.npz"
    pa.save_weights(path, weights)
    return path


def test_pack_writes_what_write_asset_writes(tmp_path, weights, weights_file):
    out = tmp_path / "a.pleat"
    assert pack.main([str(weights_file), "-o", str(out), "--fp16"]) == 0
    assert out.read_bytes() == pa.write_asset(None, weights, fp16=True)


def _garment_on_the_body(tmp_path):
    """A random asset whose template is the body's own vertices pushed 1 cm out (every fifth 9 cm: too far)."""
    from pleat.body import BodyModel
    from pleat.body.model import vertex_normals
    body = BodyModel.load()
    w = random_weights(vertices=60, latent=4, blend=3, lp_hidden=(8,), dec_hidden=(6,), seed=2, body_contact=False)
    pick = np.linspace(0, body.num_vertices - 1, len(w["template"])).astype(int)
    push = np.where(np.arange(len(pick)) % 5 == 0, 0.09, 0.01)
    w["template"] = body.v_template[pick] + push[:, None] * vertex_normals(body.v_template, body.faces)[pick]
    src = tmp_path / "in.pleat"
    pa.write_asset(src, w)
    assert "body_anchor" not in pa.read_asset(src.read_bytes())
    return body, w, pick, src


def _unchanged_but_contact(back, before):
    contact = set(pa.BODY_CONTACT_KEYS) | {pa.BODY_CONTACT_CANDIDATES_KEY, pa.BODY_CONTACT_RING_KEY}
    for key, value in before.items():
        if key != "metadata_json" and key not in contact:
            np.testing.assert_array_equal(np.asarray(back[key]), np.asarray(value), err_msg=key)
    meta, meta_before = json.loads(back["metadata_json"]), json.loads(before["metadata_json"])
    contact_meta = meta.pop("body_contact")
    assert meta == meta_before                                         # META says how, nothing else changes
    return contact_meta


def test_repacking_an_asset_adds_body_contact_and_keeps_everything_else(tmp_path):
    """pleat-pack IN.pleat --body-contact (asset 1.2): the points are body vertices; each near garment vertex's
    candidates are its 4 nearest, nearest first, with their normals and their own top-4 skin weights; the far ones
    and the pinned ones have none; each candidate has its ring of body neighbours, counter-clockwise from outside (its rest fan's normal
    is its rest normal); ring corners that are no candidate never anchor; every other section is unchanged."""
    from scipy.spatial import cKDTree
    body, w, pick, src = _garment_on_the_body(tmp_path)
    out = tmp_path / "out.pleat"
    assert pack.main([str(src), "-o", str(out), "--body-contact"]) == 0
    back, before = pa.read_asset(out.read_bytes()), pa.read_asset(src.read_bytes())
    meta = _unchanged_but_contact(back, before)
    assert meta["vertices"] == len(pick) and meta["candidates"] == 4 and meta["posed_normals"]
    gap, vertex = cKDTree(body.v_template).query(back["body_anchor"].astype(np.float64))
    np.testing.assert_allclose(gap, 0.0, atol=1e-6)                    # every point is a body vertex
    table, P = back["body_anchor_candidates"].astype(int), len(vertex)
    far = cKDTree(body.v_template).query(w["template"])[0] > 0.05      # no body vertex within 5 cm
    far[np.asarray(w["pinned"])] = True                                 # pinned: skinned, never pushed
    assert np.all(table[far] == pa.NO_CANDIDATE) and np.all(table[~far] < P) and np.any(far)
    to_slot = np.linalg.norm(w["template"][~far, None] - body.v_template[vertex[table[~far]]], axis=2)
    assert np.all(np.diff(to_slot, axis=1) >= -1e-9)                   # nearest first …
    to_pick = np.linalg.norm(w["template"][~far] - body.v_template[pick[~far]], axis=1)
    assert np.all(to_slot[:, 0] <= to_pick + 1e-9)                     # … and no farther than the pushed-out vertex
    candidate = np.zeros(P, bool)
    candidate[table[~far].ravel()] = True
    length = np.linalg.norm(back["body_anchor_normal"], axis=1)
    np.testing.assert_allclose(length[candidate], 1.0, atol=1e-6)
    np.testing.assert_array_equal(length[~candidate], 0.0)             # ring corners only: never an anchor
    ring = back["body_anchor_ring"].astype(int)
    edges = {tuple(sorted(e)) for f in body.faces for e in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))}
    for p in np.flatnonzero(candidate):
        r = ring[p][ring[p] < P]
        assert len(r) >= 3 and all(tuple(sorted((vertex[p], vertex[q]))) in edges for q in r)
        d = body.v_template[vertex[r]] - body.v_template[vertex[p]]
        fan = np.cross(d, np.roll(d, -1, axis=0)).sum(axis=0)
        assert np.dot(fan, back["body_anchor_normal"][p]) > 0.9 * np.linalg.norm(fan)
    top = np.argmax(body.weights[vertex], axis=1)
    assert all(t in row for t, row in zip(top, back["body_anchor_skin_indices"]))


def test_pack_one_candidate_with_rest_normals_writes_the_asset_1_1_block(tmp_path):
    """--contact-candidates 1 --contact-rest-normals: one point per vertex, its nearest body vertex (as near as the
    one pushed out), a zero normal beyond 5 cm, no candidate table or rings; a bad count is refused."""
    from scipy.spatial import cKDTree
    body, w, pick, src = _garment_on_the_body(tmp_path)
    out = tmp_path / "out.pleat"
    assert pack.main([str(src), "-o", str(out), "--body-contact", "--contact-candidates", "1",
                      "--contact-rest-normals"]) == 0
    back = pa.read_asset(out.read_bytes())
    assert pa.BODY_CONTACT_CANDIDATES_KEY not in back and pa.BODY_CONTACT_RING_KEY not in back
    _unchanged_but_contact(back, pa.read_asset(src.read_bytes()))
    gap, anchor = cKDTree(body.v_template).query(back["body_anchor"].astype(np.float64))
    np.testing.assert_allclose(gap, 0.0, atol=1e-6)
    to_anchor = np.linalg.norm(w["template"] - body.v_template[anchor], axis=1)
    to_pick = np.linalg.norm(w["template"] - body.v_template[pick], axis=1)
    assert np.all(to_anchor <= to_pick + 1e-9)
    length = np.linalg.norm(back["body_anchor_normal"], axis=1)
    near = to_anchor < 0.05
    near[np.asarray(w["pinned"])] = False                               # pinned vertices never anchor
    assert len(w["pinned"]) > 0
    np.testing.assert_allclose(length[near], 1.0, atol=1e-6)
    np.testing.assert_array_equal(length[~near], 0.0)
    assert pack.main([str(src), "-o", str(out), "--body-contact", "--contact-candidates", "17"]) != 0


def test_pack_takes_candidates_chosen_elsewhere(tmp_path):
    """--contact-candidates-from FILE.npz (candidate_vertices: body vertex ids [N, C], -1 none; pleat-train
    contact-candidates chooses them from simulated frames): each vertex's first candidate is still its rest-nearest
    body vertex, the others are the file's in its order (a repeat dropped), far vertices have none, every candidate has
    its ring; META says where they came from; a bad file or a count that disagrees is refused."""
    from scipy.spatial import cKDTree
    body, w, pick, src = _garment_on_the_body(tmp_path)
    N, C = len(w["template"]), 5
    rng = np.random.default_rng(3)
    given = rng.integers(0, body.num_vertices, (N, C))
    given[:, 0] = 0                                                    # ignored: the first stays the rest-nearest
    given[1, 2] = given[1, 1]                                          # a repeat: dropped, the rest moves up
    given[2, 3:] = -1                                                  # fewer candidates
    np.savez(tmp_path / "cand.npz", candidate_vertices=given)
    out = tmp_path / "out.pleat"
    assert pack.main([str(src), "-o", str(out), "--body-contact", "--contact-candidates-from",
                      str(tmp_path / "cand.npz")]) == 0
    back = pa.read_asset(out.read_bytes())
    meta = _unchanged_but_contact(back, pa.read_asset(src.read_bytes()))
    assert meta["candidates"] == C and meta["candidates_from"] == "simulated frames"
    _, vertex = cKDTree(body.v_template).query(back["body_anchor"].astype(np.float64))
    table = back["body_anchor_candidates"].astype(int)
    P = len(vertex)
    own = cKDTree(body.v_template).query(w["template"])[1]
    far = cKDTree(body.v_template).query(w["template"])[0] > 0.05
    far[np.asarray(w["pinned"])] = True                                 # pinned: no candidates either
    for i in np.flatnonzero(~far):
        ids = [int(vertex[t]) for t in table[i] if t < P]
        expect = list(dict.fromkeys([int(own[i])] + [int(g) for g in given[i, 1:] if g >= 0]))
        assert ids == expect, i
    assert np.all(table[far] == pa.NO_CANDIDATE)
    ring = back["body_anchor_ring"].astype(int)
    assert all(ring[t, 0] < P for t in np.unique(table[table < P]))     # every candidate has its ring
    np.savez(tmp_path / "bad.npz", candidate_vertices=given[:, :, None])
    assert pack.main([str(src), "-o", str(out), "--body-contact", "--contact-candidates-from",
                      str(tmp_path / "bad.npz")]) != 0
    np.savez(tmp_path / "far.npz", candidate_vertices=np.full((N, C), body.num_vertices))
    assert pack.main([str(src), "-o", str(out), "--body-contact", "--contact-candidates-from",
                      str(tmp_path / "far.npz")]) != 0
    assert pack.main([str(src), "-o", str(out), "--body-contact", "--contact-candidates", "4",
                      "--contact-candidates-from", str(tmp_path / "cand.npz")]) != 0


def test_vertices_that_meet_the_body_in_motion_get_candidates_however_far_they_hang(tmp_path):
    """A candidates file with near_in_motion (pleat-train contact-candidates keeps which vertices came within reach of
    the body in its frames): a vertex 9 cm from the rest body that met it still gets the file's candidates — its first
    slot its own row, with no normal (the fast contact, which pushes without the full contact's reach, reads row v
    and leaves it alone; the full contact skips a point without a normal) — while one that never met it, and every
    pinned vertex, gets none; META names the file's source."""
    from scipy.spatial import cKDTree
    body, w, pick, src = _garment_on_the_body(tmp_path)
    N, C = len(w["template"]), 4
    rng = np.random.default_rng(5)
    given = rng.integers(0, body.num_vertices, (N, C))
    near = np.arange(N) % 10 == 0                                      # every other far vertex (far: i % 5 == 0)
    np.savez(tmp_path / "cand.npz", candidate_vertices=given, near_in_motion=near,
             source=np.array("an asset's own garment"))
    out = tmp_path / "out.pleat"
    assert pack.main([str(src), "-o", str(out), "--body-contact", "--contact-candidates-from",
                      str(tmp_path / "cand.npz")]) == 0
    back = pa.read_asset(out.read_bytes())
    meta = _unchanged_but_contact(back, pa.read_asset(src.read_bytes()))
    assert meta["candidates_from"] == "an asset's own garment" and "an asset's own garment" in meta["anchors"]
    table = back["body_anchor_candidates"].astype(int)
    normals = back["body_anchor_normal"]
    P = len(back["body_anchor"])
    _, vertex = cKDTree(body.v_template).query(back["body_anchor"].astype(np.float64))
    rest_far = cKDTree(body.v_template).query(w["template"])[0] > 0.05
    pinned = np.zeros(N, bool)
    pinned[np.asarray(w["pinned"])] = True
    reached = rest_far & near & ~pinned
    assert reached.sum() >= 2 and (rest_far & ~near & ~pinned).sum() >= 2
    for i in np.flatnonzero(reached):
        assert table[i, 0] == i and not normals[i].any(), i             # its own row: no plane
        ids = [int(vertex[t]) for t in table[i, 1:] if t < P]
        assert ids == [int(g) for g in dict.fromkeys(given[i, 1:]) if g != vertex[i]][:len(ids)] and ids, i
        assert all(normals[t].any() for t in table[i, 1:] if t < P), i  # the file's candidates are planes
    assert np.all(table[rest_far & ~near] == pa.NO_CANDIDATE)
    assert np.all(table[pinned] == pa.NO_CANDIDATE)
    for i in np.flatnonzero(~rest_far & ~pinned):
        assert normals[table[i, 0]].any(), i                           # a near vertex's own row stays a plane


def test_pack_name_and_metadata_override(tmp_path, weights_file):
    out = tmp_path / "a.pleat"
    assert pack.main([str(weights_file), "-o", str(out), "--name", "shirt", "--metadata", '{"loss": 0.5}']) == 0
    back = pa.read_asset(out.read_bytes())
    assert back["garment_name"] == "shirt" and json.loads(back["metadata_json"]) == {"loss": 0.5}
    assert pack.main([str(weights_file), "-o", str(out), "--metadata", "{bad"]) == 1


def test_info_prints_header_sections_counts_and_meta(tmp_path, weights_file, capsys):
    out = tmp_path / "a.pleat"
    pack.main([str(weights_file), "-o", str(out), "--onnx", "--name", "tee"])
    capsys.readouterr()
    assert pack.main(["--info", str(out)]) == 0
    text = capsys.readouterr().out
    for needle in ("Pleat asset 1.2", "CRC-32", "(ok)", "TMPL", "BANC", "BASW", "OXLP", "OXDC", "vertex_count=100", "latent_count=8",
                   "name: tee", "META:", "validation: ok"):
        assert needle in text, needle
    data = bytearray(out.read_bytes())
    data[-5] ^= 1
    out.write_bytes(bytes(data))
    assert pack.main(["--info", str(out)]) == 1
    assert "MISMATCH" in capsys.readouterr().out


def test_pack_path_does_not_import_torch(tmp_path, weights_file):
    code = ("import sys; from pleat import pack; "
            f"rc = pack.main([{str(weights_file)!r}, '-o', {str(tmp_path / 'a.pleat')!r}, '--onnx']); "
            "sys.exit(10 if 'torch' in sys.modules else rc)")
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


def run_onnx(model_bytes, feed):
    ort = pytest.importorskip("onnxruntime")
    session = ort.InferenceSession(model_bytes, providers=["CPUExecutionProvider"])
    return session.run(None, feed)[0]


@pytest.mark.parametrize("activation", ["relu", "silu"])
@pytest.mark.parametrize("fp16", [False, True])
def test_embedded_onnx_matches_the_numpy_reference(weights, activation, fp16):
    w = dict(weights, lp_activation=activation, dec_activation=activation)
    back = pa.read_asset(pa.write_asset(None, w, fp16=fp16, onnx=True))
    rng = np.random.default_rng(0)
    x = rng.standard_normal((1, len(back["x_mean"]))).astype(np.float32)
    z = rng.standard_normal((1, 8)).astype(np.float32)
    y = run_onnx(back["onnx_latent_predictor"], {"x": x})
    wts = run_onnx(back["onnx_decoder"], {"z": z})
    assert y.shape == (1, 8) and wts.shape == (1, 6)
    # the reference uses the weights as stored (fp16-rounded when fp16): ONNX must compute the same function
    np.testing.assert_allclose(y, mlp(x, *layers(back, "lp"), activation), rtol=1e-4, atol=1e-5)
    np.testing.assert_allclose(wts, mlp(z, *layers(back, "dec"), activation), rtol=1e-4, atol=1e-5)


def test_export_onnx_writes_standalone_models(tmp_path, weights, weights_file):
    onnx = pytest.importorskip("onnx")
    assert pack.main([str(weights_file), "--export-onnx", str(tmp_path / "ox")]) == 0
    lp = onnx.load(str(tmp_path / "ox" / "latent_predictor.onnx"))
    dec = onnx.load(str(tmp_path / "ox" / "decoder.onnx"))
    assert [i.name for i in lp.graph.input] == ["x"] and [o.name for o in lp.graph.output] == ["y"]
    assert [i.name for i in dec.graph.input] == ["z"] and [o.name for o in dec.graph.output] == ["w"]
    dims = lambda v: [d.dim_value for d in v.type.tensor_type.shape.dim]
    assert dims(lp.graph.input[0]) == [1, len(weights["x_mean"])] and dims(dec.graph.output[0]) == [1, 6]
    assert {n.op_type for n in lp.graph.node} == {"Gemm", "Relu"}


def test_candidates_on_body_parts_the_garment_passes_through_are_dropped(tmp_path):
    """A candidates file that names body vertices of a part META's collision_exclude leaves out (the dress and the
    forearms): those are no candidate of any vertex, as the simulator never collides the garment with them."""
    body, w, pick, src = _garment_on_the_body(tmp_path)
    names = [str(n) for n in w["joint_names"]]
    owner = np.argmax(np.asarray(body.weights), axis=1)                    # each body vertex's joint
    excluded_joint = int(owner[pick[1]])
    w["metadata_json"] = json.dumps({"collision_exclude": [names[excluded_joint]]})
    pa.write_asset(src, w)
    N, C = len(w["template"]), 4
    given = np.tile(np.flatnonzero(owner == excluded_joint)[:C], (N, 1))   # only excluded body vertices
    given[:, 2] = np.flatnonzero(owner != excluded_joint)[0]               # and one allowed
    np.savez(tmp_path / "cand.npz", candidate_vertices=given)
    out = tmp_path / "out.pleat"
    assert pack.main([str(src), "-o", str(out), "--body-contact", "--contact-candidates-from",
                      str(tmp_path / "cand.npz")]) == 0
    back = pa.read_asset(out.read_bytes())
    from scipy.spatial import cKDTree
    _, vertex = cKDTree(body.v_template).query(back["body_anchor"].astype(np.float64))
    table = back["body_anchor_candidates"].astype(int)
    used = vertex[table[table < len(vertex)]]
    assert len(used) > 0 and not np.any(owner[used] == excluded_joint)
