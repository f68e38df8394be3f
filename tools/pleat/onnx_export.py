"""The two MLPs as ONNX graphs, built with onnx.helper from the weights (no PyTorch).

Latent predictor: input `x` [1, I] (already normalised) → output `y` [1, L]. Decoder: input `z` [1, L] → `w` [1, D].
Each layer is Gemm(h, W, b, transB=1) (W in torch Linear layout [out, in]); hidden layers are followed by Relu, or
Sigmoid·x for SiLU. Weights are fp32 (fp16-stored weights are widened, so ONNX and the native path use the same
values). Opset 13 and IR version 7 keep the models loadable by old ONNX Runtime releases too.
"""
import numpy as np

OPSET = 13
IR_VERSION = 7


def mlp_model(weights, biases, activation, input_name, output_name, graph_name):
    """Serialised ONNX ModelProto (bytes) of an MLP: hidden layers with `activation` ('relu'/'silu'), last linear."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    nodes, inits = [], []
    h = input_name
    for i, (w, b) in enumerate(zip(weights, biases)):
        w = np.asarray(w, np.float32)
        b = np.asarray(b, np.float32)
        inits += [numpy_helper.from_array(w, f"layer{i}.weight"), numpy_helper.from_array(b, f"layer{i}.bias")]
        last = i + 1 == len(weights)
        out = output_name if last else f"layer{i}.linear"
        nodes.append(helper.make_node("Gemm", [h, f"layer{i}.weight", f"layer{i}.bias"], [out], transB=1,
                                      name=f"layer{i}.gemm"))
        if not last:
            if activation == "relu":
                nodes.append(helper.make_node("Relu", [out], [f"layer{i}.act"], name=f"layer{i}.relu"))
            elif activation == "silu":
                nodes.append(helper.make_node("Sigmoid", [out], [f"layer{i}.sigmoid"], name=f"layer{i}.sigmoid"))
                nodes.append(helper.make_node("Mul", [out, f"layer{i}.sigmoid"], [f"layer{i}.act"],
                                              name=f"layer{i}.silu"))
            else:
                raise ValueError(f"unknown activation {activation!r}")
            h = f"layer{i}.act"
    in_count = np.asarray(weights[0]).shape[1]
    out_count = np.asarray(weights[-1]).shape[0]
    graph = helper.make_graph(nodes, graph_name,
                              [helper.make_tensor_value_info(input_name, TensorProto.FLOAT, [1, in_count])],
                              [helper.make_tensor_value_info(output_name, TensorProto.FLOAT, [1, out_count])],
                              initializer=inits)
    model = helper.make_model(graph, producer_name="pleat-pack", opset_imports=[helper.make_opsetid("", OPSET)])
    model.ir_version = IR_VERSION
    onnx.checker.check_model(model)
    return model.SerializeToString()


def _layers(w, prefix):
    n = 0
    while f"{prefix}.{n}.weight" in w:
        n += 1
    return [w[f"{prefix}.{i}.weight"] for i in range(n)], [w[f"{prefix}.{i}.bias"] for i in range(n)]


def latent_predictor_model(w):
    """OXLP: x [1, I] normalised → y [1, L]."""
    weights, biases = _layers(w, "lp")
    return mlp_model(weights, biases, str(w.get("lp_activation", "relu")), "x", "y", "pleat_latent_predictor")


def decoder_model(w):
    """OXDC: z [1, L] → w [1, D]."""
    weights, biases = _layers(w, "dec")
    return mlp_model(weights, biases, str(w.get("dec_activation", "relu")), "z", "w", "pleat_decoder")


def export(w, out_dir):
    """Writes latent_predictor.onnx and decoder.onnx into out_dir; returns their paths."""
    from pathlib import Path

    from pleat.fileio import write_bytes
    models = (latent_predictor_model(w), decoder_model(w))      # both built before either file is touched
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "latent_predictor.onnx", out / "decoder.onnx"]
    for path, model in zip(paths, models):
        write_bytes(path, model)
    return paths
