"""pleat-pack: weights file (.npz / .safetensors) → Pleat asset (.pleat), and asset inspection. No PyTorch.

    pleat-pack WEIGHTS.npz --out OUT.pleat [--fp16] [--int8 [--calibration X_C.npz]] [--int8-blend-shapes] [--onnx]
               [--name NAME] [--metadata JSON] [--export-onnx DIR]
               [--body-contact [BODY.npz]] [--contact-candidates C] [--contact-rest-normals]
    pleat-pack IN.pleat --out OUT.pleat --body-contact      # repack an asset, adding (or redoing) its body contact
    pleat-pack --info FILE.pleat
"""
import argparse
import json
import sys
import zipfile
from pathlib import Path

import numpy as np

from pleat import asset as pa
from pleat.cli import InputError, add_quiet, command, not_npz

DTYPE_NAMES = {pa.DTYPE_F32: "f32", pa.DTYPE_F16: "f16", pa.DTYPE_U32: "u32", pa.DTYPE_U16: "u16",
               pa.DTYPE_I32: "i32", pa.DTYPE_U8: "u8", pa.DTYPE_I8: "i8"}


def info(path, out=None):
    """Prints header, section table, counts and META of an asset. Returns 0, or 1 if it does not validate."""
    data = Path(path).read_bytes()
    header, sections = pa.inspect_asset(data, verify_checksum=False)
    crc_ok = pa.checksum(data) == header["checksum"]
    p = lambda *a: print(*a, file=out or sys.stdout)
    p(f"{path}: Pleat asset {header['version'][0]}.{header['version'][1]}, {header['file_size']} bytes, "
      f"{header['section_count']} sections, flags 0x{header['flags']:x}"
      f"{' (fp16 weights)' if header['flags'] & pa.FLAG_FP16 else ''}"
      f"{' (int8 networks)' if header['flags'] & pa.FLAG_INT8 else ''}"
      f"{' (ranged int8 inputs)' if header['flags'] & pa.FLAG_INT8_RANGED_INPUTS else ''}"
      f"{' (int8 blend shapes)' if header['flags'] & pa.FLAG_INT8_BLEND_SHAPES else ''}, "
      f"CRC-32 {header['checksum']:08x} "
      f"({'ok' if crc_ok else 'MISMATCH'})")
    p(f"  {'fourcc':6} {'dtype':5} {'offset':>10} {'size':>10}  dims")
    for s in sections:
        p(f"  {s['fourcc']:6} {DTYPE_NAMES[s['dtype']]:5} {s['offset']:>10} {s['size']:>10}  "
          f"[{', '.join(map(str, s['dims']))}]")
    by = {s["fourcc"]: s for s in sections}
    if "CONF" in by and by["CONF"]["size"] == pa.CONF_SIZE:
        off = by["CONF"]["offset"]
        conf = pa.read_conf(data[off:off + pa.CONF_SIZE])
        p("  counts: " + ", ".join(f"{k}={conf[k]}" for k in pa._CONF_U32_FIELDS if not k.endswith("activation")))
        p(f"  activations: lp={pa.ACTIVATION_NAMES.get(conf['lp_activation'], '?')} "
          f"dec={pa.ACTIVATION_NAMES.get(conf['dec_activation'], '?')}")
        fmt = lambda v: "[" + ", ".join(f"{x:.6g}" for x in v) + "]"
        p(f"  dt_range_s={fmt(conf['dt_range_s'])} beta_range={fmt(conf['beta_range'])} "
          f"train_fps={conf['train_fps']:.6g}")
        p(f"  material_min={fmt(conf['material_min'])} material_max={fmt(conf['material_max'])} "
          f"material_default={fmt(conf['material_default'])}")
    for tag, label in (("NAME", "name"), ("META", "META")):
        if tag in by:
            s = by[tag]
            p(f"  {label}: {data[s['offset']:s['offset'] + s['size']].decode('utf-8', 'replace')}")
    try:
        pa.read_asset(data)
        p("  validation: ok")
        return 0
    except pa.AssetError as e:
        p(f"  validation: FAILED ({e.code}: {e})")
        return 1


def build_parser():
    p = argparse.ArgumentParser(prog="pleat-pack", description="Pack a Pleat weights file into a .pleat asset.")
    p.add_argument("weights", nargs="?",
                   help="weights file (.npz or .safetensors, keys per docs/asset-format.md), or a .pleat to repack")
    p.add_argument("-o", "--out", "--output", dest="output",
                   help="output file: the asset (.pleat); --output is the older name")
    p.add_argument("--fp16", action="store_true", help="store LP/decoder weight matrices and BLND as fp16")
    p.add_argument("--int8", action="store_true",
                   help="int8 networks (asset 1.3): weights per output channel, each layer's input scale calibrated "
                        "on --calibration's rows (default: random normalised inputs), inputs ranged where the "
                        "networks are ReLU (docs/asset-format.md); with --fp16, BLND is fp16")
    p.add_argument("--int8-blend-shapes", action="store_true",
                   help="int8 blend shapes (asset 1.4): one scale per shape, a quarter of fp32's bytes and half of "
                        "fp16's, which is what a large garment's step streams (docs/asset-format.md)")
    p.add_argument("--precision", choices=("fp32", "fp16", "int8"),
                   help="the networks' precision: fp16 = --fp16, int8 = --int8")
    p.add_argument("--calibration", metavar="NPZ",
                   help="with --int8: X_c rows [M, I] under 'x_c' (pleat-quantise collect makes them from "
                        "clips)")
    p.add_argument("--symmetric-inputs", action="store_true",
                   help="with --int8: every layer's input quantised to -127..127, as the first int8 assets (default: "
                        "ranged inputs where the networks are ReLU)")
    p.add_argument("--calibration-percentile", type=float, default=100.0, metavar="P",
                   help="with --int8: each layer's input range is this percentile of |value| (default 100: the "
                        "largest)")
    p.add_argument("--onnx", action="store_true", help="embed the MLPs as ONNX models (OXLP, OXDC; with --int8 the "
                                                       "float networks it was quantised from)")
    p.add_argument("--name", help="garment name (overrides garment_name)")
    p.add_argument("--metadata", help="META JSON: inline JSON text or a path to a .json file (overrides metadata_json)")
    p.add_argument("--export-onnx", metavar="DIR", help="also write latent_predictor.onnx and decoder.onnx to DIR")
    p.add_argument("--body-contact", nargs="?", const="", default=None, metavar="BODY",
                   help="add body contact (asset 1.2: body points, candidates, rings) computed against this body npz (default: the "
                        "shipped body, assets/body.npz)")
    p.add_argument("--contact-candidates", type=int, default=None, metavar="C",
                   help="with --body-contact: candidate body points per garment vertex (1..16, default 4; "
                        "docs/asset-format.md \"Body contact\")")
    p.add_argument("--contact-candidates-from", metavar="NPZ",
                   help="with --body-contact: each garment vertex's candidates after its rest-nearest body vertex, "
                        "as body vertex ids [N, C] (-1: none) under 'candidate_vertices' (pleat-train "
                        "contact-candidates: the body vertices nearest to it in simulated frames); C sets "
                        "--contact-candidates")
    p.add_argument("--contact-rest-normals", action="store_true",
                   help="with --body-contact: turn each point's rest normal by its blended matrix instead of taking "
                        "the posed body's normal (cheaper, less exact near the joints); with --contact-candidates 1 "
                        "this writes the asset 1.1 block")
    p.add_argument("--info", metavar="FILE", help="print header, sections, counts and META of an asset and exit")
    add_quiet(p)
    return p


def _collide(weights, body):
    """The body vertices the garment collides with, from META's collision_exclude (joint names; the dress leaves
    out the forearms and hands), or None for the whole body: the redone contact keeps the choice the asset was made
    with."""
    from pleat.garment.garment import body_collision_mask
    meta = json.loads(str(weights["metadata_json"])) if weights.get("metadata_json") is not None else {}
    names = [str(n) for n in weights["joint_names"]]
    return body_collision_mask([names.index(n) for n in meta.get("collision_exclude", [])], body)


def _quantised(a, weights):
    """The weights with int8 networks (pleat.quantise), calibrated on --calibration's rows or random ones; META (if
    any) records how under 'int8'."""
    from pleat import quantise as pq
    x_c = None
    if a.calibration:
        try:
            with np.load(a.calibration, allow_pickle=False) as z:
                x_c = np.asarray(z[pq.CALIBRATION_KEY], np.float64)
        except Exception as e:   # noqa: BLE001 - numpy raises many kinds on a bad file
            if isinstance(e, OSError) and e.filename is not None:
                raise
            raise not_npz(a.calibration, e, f"a calibration file ('{pq.CALIBRATION_KEY}')") from None
    try:
        x = pq.normalised_inputs(weights, x_c)
        quantised, record = pq.quantise(weights, x, a.calibration_percentile,
                                        ranged=False if a.symmetric_inputs else None)
    except (ValueError, KeyError) as e:
        raise InputError(a.calibration or a.weights, f"cannot be quantised ({e})") from None
    record["calibration"] = Path(a.calibration).name if a.calibration else "random normalised inputs ~ N(0, 1)"
    if quantised.get("metadata_json") is not None:
        meta = json.loads(str(quantised["metadata_json"]))
        meta["int8"] = record
        quantised["metadata_json"] = json.dumps(meta, sort_keys=True)
    return quantised


@command("pleat-pack")
def main(argv=None):
    p = build_parser()
    a = p.parse_args(argv)
    if a.info:
        try:
            return info(a.info)
        except pa.AssetError as e:
            raise InputError(a.info, f"not a valid Pleat asset ({e})") from None
    if not a.weights or not (a.output or a.export_onnx):
        p.error("need WEIGHTS and -o OUT.pleat (or --export-onnx DIR), or --info FILE")
    if a.precision == "fp16":
        a.fp16 = True
    elif a.precision == "int8":
        a.int8 = True
    if (a.calibration or a.calibration_percentile != 100.0 or a.symmetric_inputs) and not a.int8:
        p.error("--calibration, --calibration-percentile and --symmetric-inputs go with --int8")
    if not 0.0 < a.calibration_percentile <= 100.0:
        p.error("--calibration-percentile: must be in (0, 100]")
    try:
        if Path(a.weights).suffix == ".pleat":
            weights = pa.read_asset(Path(a.weights).read_bytes())
            weights = {k: v for k, v in weights.items() if not k.startswith("onnx_")}   # --onnx rebuilds them
        else:
            weights = pa.load_weights(a.weights)
    except pa.AssetError as e:
        raise InputError(a.weights, f"not a valid Pleat asset ({e.code}: {e})") from None
    except Exception as e:   # noqa: BLE001 - numpy and safetensors raise many kinds on a bad file
        if isinstance(e, OSError) and e.filename is not None:
            raise
        if Path(a.weights).suffix == ".safetensors":
            raise InputError(a.weights, f"not a safetensors weights file ({type(e).__name__}: {e})") from None
        raise not_npz(a.weights, e, "a weights file") from None
    if a.body_contact is not None:
        from pleat.body import BodyModel
        from pleat.garment_asset import BODY_CONTACT_CANDIDATES, body_anchors, body_contact_meta
        if a.contact_candidates is not None and not 1 <= a.contact_candidates <= pa.MAX_CONTACT_CANDIDATES:
            raise InputError("--contact-candidates", f"{a.contact_candidates}: must be 1..{pa.MAX_CONTACT_CANDIDATES}")
        found = None
        if a.contact_candidates_from:
            from pleat.garment_asset import read_candidates
            try:
                found = read_candidates(a.contact_candidates_from)
            except Exception as e:   # noqa: BLE001 - numpy raises many kinds on a bad file
                if isinstance(e, OSError) and e.filename is not None:
                    raise
                raise not_npz(a.contact_candidates_from, e, "a candidates file ('candidate_vertices')") from None
            given = found.table
            if given.ndim != 2 or not 1 <= given.shape[1] <= pa.MAX_CONTACT_CANDIDATES:
                raise InputError(a.contact_candidates_from,
                                 f"candidate_vertices: expected [N, C] with C in 1..{pa.MAX_CONTACT_CANDIDATES}, "
                                 f"got {given.shape}")
            if a.contact_candidates is not None and a.contact_candidates != given.shape[1]:
                raise InputError("--contact-candidates", f"{a.contact_candidates}: the candidates file has "
                                                         f"{given.shape[1]}")
            a.contact_candidates = given.shape[1]
        for key in ("body_anchor_candidates", "body_anchor_ring"):   # the new block replaces any earlier one whole
            weights.pop(key, None)
        try:
            body = BodyModel.load(a.body_contact or None)
            weights.update(body_anchors(weights["template"], body,
                                        candidates=a.contact_candidates or BODY_CONTACT_CANDIDATES,
                                        posed_normals=not a.contact_rest_normals,
                                        candidate_vertices=found.table if found else None,
                                        near_in_motion=found.near if found else None,
                                        collide=_collide(weights, body), pinned=weights.get("pinned")))
        except ValueError as e:
            raise InputError(a.contact_candidates_from or "--body-contact", str(e)) from None
        if weights.get("metadata_json") is not None:
            meta = json.loads(str(weights["metadata_json"]))
            meta["body_contact"] = body_contact_meta(weights, from_frames=found.source if found else False)
            weights["metadata_json"] = json.dumps(meta, sort_keys=True)
    if a.name is not None:
        weights["garment_name"] = a.name
    if a.metadata is not None:
        text = Path(a.metadata).read_text() if a.metadata.endswith(".json") and Path(a.metadata).is_file() \
            else a.metadata
        try:
            json.loads(text)
        except json.JSONDecodeError as e:
            raise InputError(a.metadata if text is not a.metadata else "--metadata", f"not valid JSON ({e})") \
                from None
        weights["metadata_json"] = text
    float_weights = weights
    if a.int8:
        weights = _quantised(a, weights)
    if a.int8_blend_shapes and not pa.has_int8_blend_shapes(weights):
        from pleat import quantise as pq
        try:
            weights, record = pq.quantise_blend_shapes(weights)
        except (KeyError, ValueError) as e:
            raise InputError(a.weights, f"blend shapes cannot be quantised ({e})") from None
        if weights.get("metadata_json") is not None:
            meta = json.loads(str(weights["metadata_json"]))
            meta["int8_blend_shapes"] = record
            weights["metadata_json"] = json.dumps(meta, sort_keys=True)
    try:
        # everything is built and validated before the first file is written (each write is atomic)
        w = pa.validate_weights(weights, fp16=a.fp16)
        if a.int8:
            w = pa.validate_weights(float_weights)        # --export-onnx: the float networks
        if a.output:
            data = pa.write_asset(a.output, weights, fp16=a.fp16, onnx=a.onnx,
                                  onnx_weights=float_weights if a.int8 else None)
            if not a.quiet:
                print(f"wrote {a.output}: {len(data)} bytes", file=sys.stderr)
        if a.export_onnx:
            from pleat import onnx_export
            for path in onnx_export.export(w, a.export_onnx):
                if not a.quiet:
                    print(f"wrote {path}", file=sys.stderr)
    except (ValueError, KeyError) as e:
        raise InputError(a.weights, f"cannot be packed ({type(e).__name__}: {e})") from None
    return 0


if __name__ == "__main__":
    sys.exit(main())
