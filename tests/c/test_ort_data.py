"""Test data for tests/c/test_ort_backend.c: small MLPs as ONNX models, built with the `onnx` package alone.

    python tests/c/test_ort_data.py OUT_DIR

writes, per model NAME in (lp, dec):
  NAME.onnx     the MLP as an ONNX graph (Gemm with transB = 1 per layer, as torch.nn.Linear stores weights; ReLU or
                SiLU = x * Sigmoid(x) between layers, the last layer linear), input [1, I] float, output [1, O] float
  NAME.cases    little-endian: "PLORTC01", u32 input_count, u32 output_count, u32 layer_count, u32 activation
                (1 = ReLU, 2 = SiLU), u32 case_count, then per case f32 input[I] and f64 expected[O] (numpy, float64
                arithmetic on the same fp32 weights)
  NAME.weights  little-endian: per layer u32 out, u32 in, f32 weight[out][in], f32 bias[out] (for Pleat's own kernel)
and `library.txt`: the path of libonnxruntime.so* inside the onnxruntime wheel of this Python. For the instance-level
test it also writes `instance.pleat` (pleat.reference.golden.random_weights at small sizes, SiLU, with the OXLP/OXDC
sections of `pleat-pack --onnx`) and `instance.motion`: "PLORTM01", u32 frame_count, u32 joint_count, f32 beta[B]
(B = 10), f32 material[4], then per frame f32 rotations[J][4] (x, y, z, w), f32 root_translation[3],
f32 root_rotation[4], f32 dt_s. Without the pleat tools package those two files are skipped (exit status stays 0).
Exit status 3 when onnx or onnxruntime is not importable (the C test then skips).
"""
import glob
import os
import struct
import sys

import numpy as np

ACTIVATIONS = {"relu": 1, "silu": 2}


def make_weights(rng, sizes):
    layers = []
    for fan_in, fan_out in zip(sizes[:-1], sizes[1:]):
        # He-style scale keeps activations O(1) through the depth, so a tolerance relative to 1 is meaningful.
        weight = (rng.standard_normal((fan_out, fan_in)) * np.sqrt(2.0 / fan_in)).astype(np.float32)
        bias = (rng.standard_normal(fan_out) * 0.1).astype(np.float32)
        layers.append((weight, bias))
    return layers


def reference(layers, activation, x):
    """float64 forward pass: hidden layers activated, last layer linear."""
    h = x.astype(np.float64)
    for i, (weight, bias) in enumerate(layers):
        h = h @ weight.astype(np.float64).T + bias.astype(np.float64)
        if i + 1 < len(layers):
            h = np.maximum(h, 0.0) if activation == "relu" else h / (1.0 + np.exp(-h))
    return h


def build_model(onnx, layers, activation, input_name, output_name):
    from onnx import TensorProto, helper, numpy_helper

    nodes, initializers = [], []
    current = input_name
    for i, (weight, bias) in enumerate(layers):
        initializers.append(numpy_helper.from_array(weight, f"W{i}"))
        initializers.append(numpy_helper.from_array(bias, f"b{i}"))
        last = i + 1 == len(layers)
        gemm_out = output_name if last else f"h{i}"
        nodes.append(helper.make_node("Gemm", [current, f"W{i}", f"b{i}"], [gemm_out], transB=1))
        current = gemm_out
        if not last:
            if activation == "relu":
                nodes.append(helper.make_node("Relu", [current], [f"a{i}"]))
            else:
                nodes.append(helper.make_node("Sigmoid", [current], [f"s{i}"]))
                nodes.append(helper.make_node("Mul", [current, f"s{i}"], [f"a{i}"]))
            current = f"a{i}"
    graph = helper.make_graph(
        nodes,
        "mlp",
        [helper.make_tensor_value_info(input_name, TensorProto.FLOAT, [1, layers[0][0].shape[1]])],
        [helper.make_tensor_value_info(output_name, TensorProto.FLOAT, [1, layers[-1][0].shape[0]])],
        initializers,
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)], producer_name="pleat-test")
    model.ir_version = 8  # readable by every onnxruntime >= 1.14
    onnx.checker.check_model(model)
    return model.SerializeToString()


def write_model(out_dir, name, sizes, activation, input_name, output_name, rng, case_count=8):
    import onnx

    layers = make_weights(rng, sizes)
    with open(os.path.join(out_dir, name + ".onnx"), "wb") as f:
        f.write(build_model(onnx, layers, activation, input_name, output_name))
    inputs = rng.standard_normal((case_count, sizes[0])).astype(np.float32)
    with open(os.path.join(out_dir, name + ".cases"), "wb") as f:
        f.write(b"PLORTC01")
        f.write(struct.pack("<5I", sizes[0], sizes[-1], len(layers), ACTIVATIONS[activation], case_count))
        for x in inputs:
            f.write(x.astype("<f4").tobytes())
            f.write(reference(layers, activation, x).astype("<f8").tobytes())
    with open(os.path.join(out_dir, name + ".weights"), "wb") as f:
        for weight, bias in layers:
            f.write(struct.pack("<2I", *weight.shape))
            f.write(weight.astype("<f4").tobytes())
            f.write(bias.astype("<f4").tobytes())


def write_instance_case(out_dir, frames=60):
    try:
        from pleat.asset import write_asset
        from pleat.reference.golden import random_motion, random_weights
    except ImportError as error:
        print(f"test_ort_data: no instance case ({error})", file=sys.stderr)
        return
    weights = random_weights(vertices=600, latent=24, blend=16, lp_hidden=(64, 64, 64), dec_hidden=(48, 48),
                             seed=5, activation="silu")
    write_asset(os.path.join(out_dir, "instance.pleat"), weights, onnx=True)
    rotations, root_translation, root_rotation, dt_s = random_motion(frames, len(weights["joint_parents"]), seed=5)
    beta = np.linspace(-1.5, 1.5, len(weights["shape_blend"]))
    material = np.asarray(weights["material_min"]) * 0.3 + np.asarray(weights["material_max"]) * 0.7
    with open(os.path.join(out_dir, "instance.motion"), "wb") as f:
        f.write(b"PLORTM01" + struct.pack("<2I", frames, rotations.shape[1]))
        f.write(np.asarray(beta, "<f4").tobytes() + np.asarray(material, "<f4").tobytes())
        for k in range(frames):
            f.write(np.concatenate([np.ravel(rotations[k]), root_translation[k], root_rotation[k], [dt_s[k]]])
                    .astype("<f4").tobytes())


def main(argv):
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    try:
        import onnx  # noqa: F401
        import onnxruntime
    except ImportError as error:
        print(f"test_ort_data: {error}", file=sys.stderr)
        return 3
    out_dir = argv[1]
    os.makedirs(out_dir, exist_ok=True)
    rng = np.random.default_rng(1234)
    # Shapes of the reference networks scaled down (the benchmark uses the full sizes): an LP-like ReLU MLP with an
    # input width that is not a multiple of 8 and a decoder-like SiLU MLP.
    write_model(out_dir, "lp", [131, 96, 96, 96, 24], "relu", "x", "y", rng)
    write_model(out_dir, "dec", [24, 64, 64, 40], "silu", "z", "w", rng)
    write_instance_case(out_dir)
    capi = os.path.join(os.path.dirname(onnxruntime.__file__), "capi")
    candidates = sorted(glob.glob(os.path.join(capi, "libonnxruntime.so*")))
    if not candidates:
        print(f"test_ort_data: no libonnxruntime.so* in {capi}", file=sys.stderr)
        return 3
    with open(os.path.join(out_dir, "library.txt"), "w") as f:
        f.write(candidates[0])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
