"""pleat.asset: the byte layout of docs/asset-format.md, round trips, and rejection of corrupt files."""
import struct
import zlib

import numpy as np
import pytest

from pleat import asset as pa
from pleat.reference.golden import random_weights


@pytest.fixture(scope="module")
def weights():
    return random_weights(vertices=150, latent=8, blend=5, lp_hidden=(16, 12), dec_hidden=(10,), seed=3)


@pytest.fixture(scope="module")
def data(weights):
    return pa.write_asset(None, weights)


def sections_of(data):
    count, table = struct.unpack_from("<I", data, 24)[0], struct.unpack_from("<Q", data, 32)[0]
    out = {}
    for i in range(count):
        fourcc, dtype, rank, _, off, size, *dims = struct.unpack_from("<4sIIIQQ4I", data, table + 48 * i)
        out[fourcc.decode()] = (dtype, rank, off, size, dims)
    return out


def refresh_crc(buf):
    buf[40:44] = b"\0\0\0\0"
    struct.pack_into("<I", buf, 40, zlib.crc32(bytes(buf)))
    return bytes(buf)


def test_header_fields_follow_the_spec(data):
    magic, major, minor, header_size, file_size, count, flags, table, crc = struct.unpack_from("<8sHHIQIIQI", data, 0)
    assert (magic, major, minor, header_size, flags, table) == (b"PLEATAST", 1, 2, 128, 0, 128)
    assert file_size == len(data)
    assert data[44:128] == bytes(84)
    zeroed = bytearray(data)
    zeroed[40:44] = bytes(4)
    assert crc == zlib.crc32(bytes(zeroed))
    assert len(sections_of(data)) == count


def test_sections_are_aligned_sized_and_disjoint(data, weights):
    secs = sections_of(data)
    itemsize = {1: 4, 2: 2, 3: 4, 4: 2, 5: 4, 6: 1}
    spans = []
    for fourcc, (dtype, rank, off, size, dims) in secs.items():
        assert off % 64 == 0 and off + size <= len(data)
        assert size == int(np.prod(dims)) * itemsize[dtype]
        assert all(d == 1 for d in dims[rank:])
        spans.append((off, off + size))
    spans.sort()
    assert all(a[1] <= b[0] for a, b in zip(spans, spans[1:]))
    assert spans[0][0] >= 128 + 48 * len(secs)
    N = len(weights["template"])
    assert secs["TMPL"][4] == [N, 3, 1, 1] and secs["TMPL"][0] == 1
    assert secs["SKNI"][0] == 4 and secs["JPAR"][0] == 5 and secs["FACE"][0] == 3
    off = secs["TMPL"][2]
    np.testing.assert_array_equal(np.frombuffer(data, "<f4", N * 3, off).reshape(N, 3),
                                  np.asarray(weights["template"], np.float32))


def test_conf_block_matches_counts(data, weights):
    off = sections_of(data)["CONF"][2]
    u = struct.unpack_from("<13I", data, off)
    L, Jin, B = 8, 19, 10
    N, F = len(weights["template"]), len(weights["faces"])
    assert u == (N, F, 24, Jin, 4, B, L, 5, 3, 2, 1, 1, L + 8 + 3 * (6 * Jin + 6) + 9 * Jin + B + 4)
    f = struct.unpack_from("<4f", data, off + 52)
    np.testing.assert_allclose(f, [1 / 240, 1 / 15, -4, 4], rtol=1e-6)
    np.testing.assert_allclose(struct.unpack_from("<4f", data, off + 68), weights["material_min"], rtol=1e-6)
    assert struct.unpack_from("<f", data, off + 116)[0] == 30.0
    assert data[off + 120:off + 256] == bytes(136)


def test_normal_adjacency_lists_each_vertex_faces_in_order():
    faces = np.array([[0, 1, 2], [2, 1, 3], [3, 4, 2], [0, 2, 4]])
    offsets, adj = pa.normal_adjacency(faces, 6)
    expected = [[f for f in range(len(faces)) if v in faces[f]] for v in range(6)]
    assert offsets.tolist() == np.cumsum([0] + [len(e) for e in expected]).tolist()
    assert adj.tolist() == sum(expected, [])


def test_round_trip_is_bit_exact(data, weights):
    back = pa.read_asset(data)
    for key, value in weights.items():
        if key in ("garment_name", "metadata_json", "lp_activation", "dec_activation"):
            assert back[key] == value
        elif key == "joint_names":
            assert list(back[key]) == list(value)
        elif np.asarray(value).dtype.kind == "f":
            np.testing.assert_array_equal(back[key], np.asarray(value, np.float32), err_msg=key)
        else:
            np.testing.assert_array_equal(back[key], value, err_msg=key)
    assert pa.write_asset(None, back) == data


def test_fp16_stores_weight_matrices_and_blend_shapes_only(weights):
    data = pa.write_asset(None, weights, fp16=True)
    assert struct.unpack_from("<I", data, 28)[0] == 1
    secs = sections_of(data)
    assert {k for k, s in secs.items() if s[0] == 2} == {"LPW0", "LPW1", "LPW2", "DCW0", "DCW1", "BLND"}
    back = pa.read_asset(data)
    assert back["lp.1.weight"].dtype == np.float16
    np.testing.assert_array_equal(back["lp.1.weight"], np.asarray(weights["lp.1.weight"]).astype(np.float16))
    np.testing.assert_array_equal(back["lp.1.bias"], np.asarray(weights["lp.1.bias"], np.float32))
    assert pa.write_asset(None, back, fp16=True) == data


@pytest.mark.parametrize("path", ["w.npz", "w.safetensors"])
def test_weights_files_round_trip(tmp_path, weights, data, path):
    pa.save_weights(tmp_path / path, weights)
    assert pa.write_asset(tmp_path / "a.pleat", pa.load_weights(tmp_path / path)) == data
    assert (tmp_path / "a.pleat").read_bytes() == data


def corrupt(data, how):
    buf = bytearray(data)
    secs = sections_of(data)
    table = 128
    index = {k: i for i, k in enumerate(secs)}
    if how == "flipped_byte":
        buf[len(buf) // 2] ^= 0x10
        return bytes(buf)
    if how == "truncated":
        return data[:-100]
    if how == "short_header":
        return data[:60]
    if how == "bad_magic":
        buf[0:8] = b"PLEATASX"
    elif how == "legacy":
        struct.pack_into("<H", buf, 8, 0)
    elif how == "newer":
        struct.pack_into("<H", buf, 8, 2)
    elif how == "misaligned":
        struct.pack_into("<Q", buf, table + 48 * index["TMPL"] + 16, secs["TMPL"][2] + 4)
    elif how == "outside":
        struct.pack_into("<Q", buf, table + 48 * index["BLND"] + 16, len(data) - 64)
    elif how == "overlap":
        struct.pack_into("<Q", buf, table + 48 * index["ZMAX"] + 16, secs["ZMIN"][2])
    elif how == "duplicate":
        buf[table + 48 * index["ZMAX"]:table + 48 * index["ZMAX"] + 4] = b"ZMIN"
    elif how == "size_mismatch":
        struct.pack_into("<Q", buf, table + 48 * index["TMPL"] + 24, secs["TMPL"][3] - 12)
    elif how == "unknown_flag":
        struct.pack_into("<I", buf, 28, 4)
    elif how == "skin_weights_sum":
        struct.pack_into("<f", buf, secs["SKNW"][2], 0.5)
    elif how == "nan_template":
        struct.pack_into("<f", buf, secs["TMPL"][2] + 8, float("nan"))
    elif how == "face_index":
        struct.pack_into("<I", buf, secs["FACE"][2] + 4, 10 ** 6)
    elif how == "parent_order":
        struct.pack_into("<i", buf, secs["JPAR"][2] + 4 * 3, 5)
    elif how == "zero_std":
        struct.pack_into("<f", buf, secs["XSTD"][2], 0.0)
    elif how == "adjacency":
        struct.pack_into("<I", buf, secs["NADF"][2], 7)
    elif how == "missing_section":
        buf[table + 48 * index["BLND"]:table + 48 * index["BLND"] + 4] = b"XXXX"
    return refresh_crc(buf)


@pytest.mark.parametrize("how,code", [
    ("flipped_byte", "CHECKSUM_MISMATCH"), ("truncated", "TRUNCATED"), ("short_header", "TRUNCATED"),
    ("bad_magic", "BAD_MAGIC"), ("legacy", "LEGACY_VERSION"), ("newer", "UNSUPPORTED_VERSION"),
    ("misaligned", "MALFORMED_ASSET"), ("outside", "MALFORMED_ASSET"), ("overlap", "MALFORMED_ASSET"),
    ("duplicate", "MALFORMED_ASSET"), ("size_mismatch", "MALFORMED_ASSET"), ("unknown_flag", "MALFORMED_ASSET"),
    ("skin_weights_sum", "INVALID_ASSET_DATA"), ("nan_template", "INVALID_ASSET_DATA"),
    ("face_index", "INVALID_ASSET_DATA"), ("parent_order", "INVALID_ASSET_DATA"),
    ("zero_std", "INVALID_ASSET_DATA"), ("adjacency", "INVALID_ASSET_DATA"),
    ("missing_section", "INVALID_ASSET_DATA")])
def test_reader_rejects_corrupt_files(data, how, code):
    with pytest.raises(pa.AssetError) as e:
        pa.read_asset(corrupt(data, how))
    assert e.value.code == code, str(e.value)


def test_reader_ignores_unknown_sections(data):
    """Minor versions only add sections: a renamed optional section (PINS → ZZZZ) must be skipped."""
    buf = bytearray(data)
    i = list(sections_of(data)).index("PINS")
    buf[128 + 48 * i:128 + 48 * i + 4] = b"ZZZZ"
    back = pa.read_asset(refresh_crc(buf))
    assert "pinned" not in back


def bad(weights, **changes):
    w = dict(weights)
    for k, v in changes.items():
        if v is None:
            del w[k]
        else:
            w[k] = v(np.array(w[k], copy=True)) if callable(v) else v
    return w


def _set(index, value):
    def f(a):
        a[index] = value
        return a
    return f


def _in_first_ring(rings, slot, value):
    rings[np.flatnonzero(rings[:, 0] != 0xFFFF)[0], slot] = value
    return rings


@pytest.mark.parametrize("change,message", [
    (dict(template=None), "template"),
    (dict(template=_set((0, 0), np.inf)), "template"),
    (dict(skin_weights=_set((0, 0), -0.1)), "skin_weights"),
    (dict(skin_weights=lambda a: a * 1.01), "skin_weights"),
    (dict(skin_indices=_set((0, 0), 24)), "skin_indices"),
    (dict(faces=_set((0, 0), 10 ** 5)), "faces"),
    (dict(faces=lambda a: np.concatenate([a[:, :1], a[:, :2]], axis=1)), "faces"),
    (dict(joint_parents=_set(2, 3)), "joint_parents"),
    (dict(input_joints=_set(0, 0)), "input_joints"),
    (dict(x_std=_set(3, 0.0)), "x_std"),
    (dict(x_mean=lambda a: a[:-1]), "x_mean"),
    (dict(**{"lp.1.weight": lambda a: a[:, :-1]}), "lp.1.weight"),
    (dict(**{"dec.1.weight": lambda a: a[:-1]}), "dec.1"),
    (dict(**{"dec.1.bias": lambda a: a[:-1]}), "dec.1.bias"),
    (dict(lp_activation="tanh"), "lp_activation"),
    (dict(material_max=lambda a: a * 0), "material_max"),
    (dict(z_min=lambda a: a + 100), "z_min"),
    (dict(garment_name="x" * 65), "garment_name"),
    (dict(metadata_json="{not json"), "metadata_json"),
    (dict(joint_names=["pelvis"] * 24), "joint_names"),
    (dict(dt_range_s=np.array([0.1, 0.01])), "dt_range_s"),
    (dict(body_anchor_candidates=_set((0, 0), 60000)), "body_anchor_candidates"),     # past P, not the empty 65535
    (dict(body_anchor_candidates=lambda a: np.repeat(a, 5, axis=1)), "body_anchor_candidates"),   # C > 16
    (dict(body_anchor_candidates=None), "points without"),                         # P != N without a table
    (dict(body_anchor_ring=lambda a: _in_first_ring(a, 1, 0xFFFF)), "body_anchor_ring"),   # a ring of one: under 3
    (dict(body_anchor_ring=lambda a: _in_first_ring(a, 2, 60000)), "body_anchor_ring"),    # past P
    (dict(body_anchor=None), "body contact"),
])
def test_writer_rejects_invalid_weights(weights, change, message):
    with pytest.raises(pa.AssetError, match=message.replace(".", r"\.")):
        pa.write_asset(None, bad(weights, **change))


def test_writer_rejects_fp16_overflow(weights):
    w = bad(weights, blend_shapes=_set((0, 0, 0), 1e6))
    pa.write_asset(None, w)                       # fine in fp32
    with pytest.raises(pa.AssetError, match="fp16"):
        pa.write_asset(None, w, fp16=True)
