"""Training configuration and schedules: the config a run resolves to (pleat.train.settings: the declared defaults,
a preset from configs/*.json, --set overrides), the loss terms and their weights over the run, the rollout length,
the optimiser, threads and the wall-clock budget."""
import math
import time

import torch

from pleat.train import settings


LOSS_TERMS = ("bending", "stretching", "inertia", "gravity", "friction", "collision")


def load_config(preset=None, path=None, overrides=None):
    """The resolved config (settings.resolve): every declared key, the preset's or file's values over the declared
    defaults, `overrides` ({"stage1.iterations": 50}) over both; settings.SettingError for an unknown key or a value
    out of range."""
    return settings.resolve(preset, path, overrides)


def lerp(a, b, s):
    return a + (b - a) * min(max(s, 0.0), 1.0)


def run_fraction(cfg1, it, elapsed_s=None, budget_s=None):
    """How far through the run iteration `it` is, in [0, 1]: by iteration count, or by wall clock when a time
    budget (--max-minutes) would end the run first, so that a budget-stopped run still goes through the whole
    rollout and collision-weight schedule."""
    s = it / max(cfg1["iterations"] - 1, 1)
    if budget_s and elapsed_s is not None:
        s = max(s, elapsed_s / budget_s)
    return min(max(s, 0.0), 1.0)


def loss_weights(cfg1, it, s=None):
    s = run_fraction(cfg1, it) if s is None else s
    c0, c1 = cfg1["collision_ramp"]
    w_c = cfg1["w_collision"][0] + (cfg1["w_collision"][1] - cfg1["w_collision"][0]) * \
        min(max((s - c0) / max(c1 - c0, 1e-9), 0.0), 1.0)
    return {"bending": cfg1["w_bending"], "stretching": cfg1["w_stretching"],
            "inertia": lerp(*cfg1["w_inertia"], s), "gravity": lerp(*cfg1["w_gravity"], s),
            "friction": cfg1["w_friction"], "collision": w_c}


def rollout_steps(cfg1, it, s=None):
    """1 step at first, one more every `rollout_every` of the run (the paper: every 5,000 of 120,000), at most
    `rollout_max`."""
    s = run_fraction(cfg1, it) if s is None else s
    return int(min(cfg1["rollout_max"], 1 + math.floor(s / cfg1["rollout_every"] + 1e-9)))


def weighted(terms, w):
    return sum(w[k] * terms[k] for k in LOSS_TERMS)


def make_optimizer(model, lr, blend_lr_scale=1.0):
    """Adam; the blend shapes D (per-vertex parameters) at `blend_lr_scale` × lr. Adam moves every parameter by
    about lr per step whatever its gradient's size, so on a 4.4k-vertex garment an lr that suits the networks
    moves each vertex of each of the D shapes independently by that much: at 5·10⁻⁴ m per step the shirt's 1.5 cm
    edges were torn apart within ten iterations (stretching 10³ → 10⁷ J)."""
    blend = [p for n, p in model.named_parameters() if n.endswith("blend_shapes")]
    rest = [p for n, p in model.named_parameters() if not n.endswith("blend_shapes")]
    return torch.optim.Adam([{"params": rest, "lr": lr}, {"params": blend, "lr": lr * blend_lr_scale}])


def set_threads(threads=None):
    """Torch intra-op threads; default 1. The graphs here are small (hundreds to a few thousand vertices, widths
    32-64), so extra threads mostly synchronise: on the shared 2-core machine (load ≈ 5) one tiny stage-1
    iteration took 0.48 s with 1 thread and 1.98 s with 2 (docs/training.md). Give more with --threads on an
    idle many-core machine."""
    torch.set_num_threads(max(1, int(threads or 1)))


class Budget:
    """Wall-clock budget of one stage (--max-minutes), counted across resumes."""

    def __init__(self, minutes, elapsed_s=0.0):
        self.budget_s = None if not minutes else 60.0 * float(minutes)
        self.t0 = time.time() - float(elapsed_s or 0.0)

    def elapsed(self):
        return time.time() - self.t0

    def spent(self):
        return self.budget_s is not None and self.elapsed() >= self.budget_s


def native_bf16(device):
    """Whether `device` multiplies bfloat16 natively: on a CPU, AVX-512 BF16 or AMX (without them oneDNN emulates
    bf16 and the matmuls are slower than float32, e.g. on AVX2-only CI machines); on a GPU, what torch reports."""
    device = torch.device(device)
    if device.type == "cuda":
        return torch.cuda.is_bf16_supported()
    if device.type != "cpu":
        return False
    cpu = torch.cpu
    return bool(getattr(cpu, "_is_avx512_bf16_supported", lambda: False)()
                or getattr(cpu, "_is_amx_tile_supported", lambda: False)())


def autocast_bf16(c1, device):
    """`stage1.autocast_bf16`: whether Φ's encoders, message passing and compressor run under bfloat16 autocast
    (matmuls in bf16 with float32 accumulation; the residual streams, the decoder, the blend shapes, the rollout and
    the losses stay float32). false (default): never; "auto": where the device has native bf16 (`native_bf16`);
    true: required, a ValueError where the device lacks it. Only the batched path has it."""
    value = c1["autocast_bf16"]
    if value is False:
        return False
    supported = native_bf16(device)
    if value is True and not supported:
        raise ValueError(f"stage1.autocast_bf16=true but {torch.device(device)} has no native bfloat16 "
                         "(CPU: AVX-512 BF16 or AMX); use \"auto\" or false")
    if value is True and not batched_path(c1):
        raise ValueError("stage1.autocast_bf16 needs the batched path (stage1.batched=true)")
    return supported and batched_path(c1)


def batched_path(c1):
    """Whether the physics-loss stages run the batched path (batching.py; default) or the per-window one
    (`--set stage1.batched=false`, kept for the A/B comparison in bench/train_throughput.py)."""
    return bool(c1["batched"])


def data_workers(c1):
    """`stage1.data_worker`: how many forked processes prepare the physics stages' windows ahead of the trainer
    (batching.WindowSource). false / 0: none; true / 1: one (what two cores can use); n: n, round robin (a GPU
    trainer on a many-core machine)."""
    return int(c1["data_worker"])


def searches_on_device(c1):
    """`stage1.nearest`: where the batched path finds each garment vertex's nearest body vertex in every rollout
    step. "kdtree": the KD-trees prepared with the windows, queried on the CPU; "torch": exact distances on the
    trainer's device (batching.nearest_on_device; float32, so a near-tie may resolve the other way); "auto"
    (default): the trees, on a CPU and on a GPU alike. Measured on an H100 with 12 data workers (docs/training-speed.md,
    "The GPU route"): K = 32 windows an iteration, 44.8 windows/s with the trees against 26.8 with the exact search
    on the GPU; on a CPU the exact search costs 30 times the trees' query."""
    return c1["nearest"] == "torch"
