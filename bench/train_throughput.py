#!/usr/bin/env python3
"""Training throughput, per-window path against the batched path, measured alternately (docs/training-speed.md).

The machine is shared, so absolute times drift with other jobs' load: every round measures each variant once (the
order reverses every round) on one setup in one process, so each pair of measurements sees about the same load;
the report gives per-variant medians over rounds, of wall time and of CPU time (all of a variant's processes: the
trainer, its data worker, both DDP ranks), and the median of the per-round ratios to the first variant of each
stage, which is the number to quote (wall; CPU where other jobs' load makes wall times of two-process variants
meaningless).

Stages and variants (the training loops' own steps: draw windows, LBS normaliser, rollout, backward, gradient
clipping, Adam):
  stage1    per-window (core: Window / rollout_loss / lbs_scale, one window per iteration — the old path),
            batched K = 1 (the same iteration through batching.py), batched K = --windows (K windows per
            iteration), the same with the data worker process (--worker), through torch.compile (--compile) and
            as two DDP processes with K/2 windows each (--ddp: the same iteration on both cores), and each of
            those with K > 1 under bf16 autocast (--bf16: stage1.autocast_bf16, an approximation of the float32
            iteration, tests/python/test_train_autocast.py)
  ablation  per-window loop over its batch of windows (the old path) against the batched one
  record    stage 2's recording of Φ's latents: per sequence (old) against groups of sequences; per frame
  stage2    one stage-2 iteration (f_LP on recorded latents, unchanged: for reference)

usage: PYTHONPATH=tools .venv/bin/python bench/train_throughput.py [--preset default] [--garment tshirt]
           [--rounds 5] [--iterations 3] [--steps 5] [--windows 8] [--worker] [--compile 1,8] [--ddp] [--bf16]
           [--threads 1] [--device cpu] [--data-workers 1] [--nearest auto[,kdtree]]
           [--more-windows 64,128]
           [--stages stage1,ablation,record,stage2]
           [--json out/bench/train_throughput.json]
"""
import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))

from pleat.train import ablation, batching, config, core  # noqa: E402


class Variant:
    def __init__(self, name, windows, step, close=None, cpu_clock=time.process_time):
        self.name, self.windows, self.step, self.close, self.cpu_clock = name, windows, step, close, cpu_clock
        self.wall, self.cpu = [], []

    def measure(self, iterations):
        w0, c0 = time.perf_counter(), self.cpu_clock()
        for _ in range(iterations):
            self.step()
        if torch.cuda.is_available():
            torch.cuda.synchronize()
        self.wall.append((time.perf_counter() - w0) / iterations)
        self.cpu.append((self.cpu_clock() - c0) / iterations)


def _cpu_clock(source):
    """CPU seconds of a variant: this process's, plus its data worker's when it has one (as the worker last reported
    them, one iteration behind: over a measurement of n iterations that is still n preparations)."""
    return (lambda: time.process_time() + source.worker_cpu_s) if source.procs else time.process_time


def optimizer_step(model, opt, objective, grad_clip):
    """One update as the trainers make it: gradients of objective, clipped to grad_clip, then the optimizer step."""
    opt.zero_grad()
    objective.backward()
    torch.nn.utils.clip_grad_norm_(model.parameters(), grad_clip)
    opt.step()


def _ddp_rank(rank, world, port, setup, clips, cfg, steps, windows, w, conn, bf16=False, use_compile=False):
    """One rank of the two-process variant: what `torchrun --nproc_per_node=2 -m pleat.train.cli stage1 --device
    cpu` runs (gloo), one iteration per message; replies with this process's CPU time so far."""
    os.environ.update(MASTER_ADDR="127.0.0.1", MASTER_PORT=str(port))
    torch.distributed.init_process_group("gloo", rank=rank, world_size=world)
    torch.set_num_threads(1)
    c1 = cfg["stage1"]
    torch.manual_seed(0)
    model = core.Stage1Model(setup)
    opt = core.make_optimizer(model, c1["lr"], c1.get("blend_lr_scale", 1.0))
    net = batching.BatchedStage1(model, bf16=bf16)
    net = torch.nn.parallel.DistributedDataParallel(batching.compiled(net) if use_compile else net)
    source = batching.WindowSource(setup, clips, np.random.default_rng([1, rank]), windows)
    c1 = dict(c1, compile=use_compile, autocast_bf16=bf16)
    while conn.recv() is not None:
        objective, _ = batching.stage1_iteration(setup, net, source, c1, steps, w, steps)
        optimizer_step(model, opt, objective, c1["grad_clip"])
        conn.send(time.process_time())
    torch.distributed.destroy_process_group()


def ddp_variant(setup, clips, cfg, steps, windows, w, bf16=False, use_compile=False):
    import multiprocessing as mp
    import socket
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    ctx = mp.get_context("fork")
    conns, procs, cpu = [], [], [0.0, 0.0]
    for rank in range(2):
        parent, child = ctx.Pipe()
        p = ctx.Process(target=_ddp_rank, args=(rank, 2, port, setup, clips, cfg, steps, windows // 2, w, child,
                                                bf16, use_compile), daemon=True)
        p.start()
        conns.append(parent)
        procs.append(p)

    def step():
        for c in conns:
            c.send(1)
        for i, c in enumerate(conns):
            cpu[i] = c.recv()

    def close():
        for c in conns:
            c.send(None)
        for p in procs:
            p.join(timeout=30)
    name = f"2 processes x K={windows // 2} (DDP)" + (" + compile" if use_compile else "") + (" + bf16" if bf16 else "")
    return Variant(name, 2 * (windows // 2), step, close, lambda: sum(cpu))


def stage1_variants(setup, clips, cfg, steps, windows, worker, compile_windows=(), ddp=False, bf16=False,
                    device_setup=None, data_workers=1, nearest=("auto",), more_windows=()):
    """The stage-1 variants. device_setup: the batched variants' setup on another device (--device cuda; the
    per-window baseline stays on the CPU, the old path as it ran); data_workers: how many worker processes the
    "+ worker" variants use; nearest: stage1.nearest of the batched variants (the first), each further one
    measured once more with the "+ worker" variant; more_windows: further K measured with the "+ worker" variant
    (one run can then find where a GPU stops gaining from larger batches)."""
    c1 = dict(cfg["stage1"], nearest=nearest[0])
    device_setup = device_setup or setup
    w = core.loss_weights(c1, 0, 0.6)            # rollouts of `steps`, collision weight on its ramp
    floor = c1.get("loss_norm_floor", 1.0)

    def model_and_opt():
        torch.manual_seed(0)
        model = core.Stage1Model(setup)
        return model, core.make_optimizer(model, c1["lr"], c1.get("blend_lr_scale", 1.0))

    def per_window():
        model, opt = model_and_opt()
        rng = np.random.default_rng(1)

        def step():                       # core.train_stage1 with stage1.batched = false
            win, beta, mat, mat01 = core.sample_window(setup, clips, rng, steps + 3)
            scale = 1.0
            if c1.get("loss_norm") == "lbs":
                scale, _ = core.lbs_scale(setup, win, beta, mat, mat01, steps, w, floor)
            loss, _ = core.rollout_loss(setup, model, core.Window(setup, win, beta, mat, mat01), steps, w)
            optimizer_step(model, opt, loss / scale, c1["grad_clip"])
        return Variant("per-window (old)", 1, step)

    def batched(k, use_worker, use_compile=False, use_bf16=False, nearest_mode=None):
        c1_k = c1 if nearest_mode is None else dict(c1, nearest=nearest_mode)
        model, opt = model_and_opt()
        model = model.to(device_setup.device)
        opt = core.make_optimizer(model, c1["lr"], c1.get("blend_lr_scale", 1.0))
        net = batching.BatchedStage1(model, bf16=use_bf16)
        if use_compile:
            net = batching.compiled(net)
        on_device = config.searches_on_device(c1_k)
        source = batching.WindowSource(device_setup, clips, np.random.default_rng(1), k,
                                       workers=data_workers if use_worker else 0, drop_trees=on_device)
        c = dict(c1_k, compile=use_compile, autocast_bf16=use_bf16)

        def step():                       # core.train_stage1 (the default)
            objective, _ = batching.stage1_iteration(device_setup, net, source, c, steps, w, steps)
            optimizer_step(model, opt, objective, c1["grad_clip"])
        workers = f" + {data_workers} workers" if data_workers > 1 else " + worker"
        return Variant(f"batched K={k}" + (workers if use_worker else "") + (" + compile" if use_compile else "")
                       + (" + bf16" if use_bf16 else "") + (" + nearest on device" if on_device else " + KD-trees"),
                       k, step, source.close, _cpu_clock(source))

    out = [per_window(), batched(1, False)]
    if windows > 1:
        out.append(batched(windows, False))
        if bf16:
            out.append(batched(windows, False, use_bf16=True))
    if worker:
        out.append(batched(windows, True))
        if bf16:
            out.append(batched(windows, True, use_bf16=True))
        for mode in nearest[1:]:
            out.append(batched(windows, True, nearest_mode=mode))
        for k in more_windows:
            out.append(batched(k, True))
            if bf16:
                out.append(batched(k, True, use_bf16=True))
    for k in compile_windows:
        out.append(batched(k, worker, True))
        if bf16:
            out.append(batched(k, worker, True, True))
    if ddp:
        out.append(ddp_variant(setup, clips, cfg, steps, windows, w))
        if bf16:
            out.append(ddp_variant(setup, clips, cfg, steps, windows, w, True, bool(compile_windows)))
    return out


def ablation_variants(setup, clips, cfg, steps, worker):
    c1, ca = cfg["stage1"], cfg["ablation"]
    w = core.loss_weights(c1, 0, 0.6)
    norms = core.pose_statistics(setup, clips, np.random.default_rng(0), samples=4)

    def model_and_opt():
        torch.manual_seed(0)
        model = core.AblationModel(setup, norms)
        return model, core.make_optimizer(model, ca["lr"], c1.get("blend_lr_scale", 1.0))

    def per_window():
        model, opt = model_and_opt()
        rng = np.random.default_rng(1)
        z_lo, z_hi = np.full(setup.L, np.inf), np.full(setup.L, -np.inf)

        def step():                       # core.train_ablation with stage1.batched = false
            loss = 0.0
            for _ in range(ca["batch"]):
                win, beta, mat, mat01 = core.sample_window(setup, clips, rng, steps + 3)
                l, _ = ablation.window_loss(setup, model, win, beta, mat, mat01, c1, steps, w, z_lo, z_hi)
                loss = loss + l / ca["batch"]
            optimizer_step(model, opt, loss, c1["grad_clip"])
        return Variant("per-window (old)", ca["batch"], step)

    def batched(use_worker):
        model, opt = model_and_opt()
        source = batching.WindowSource(setup, clips, np.random.default_rng(1), ca["batch"], static=True,
                                       workers=int(use_worker))
        z_lo, z_hi = np.full(setup.L, np.inf), np.full(setup.L, -np.inf)

        def step():                       # core.train_ablation (the default)
            objective, _ = batching.ablation_iteration(setup, model, source, c1, steps, w, z_lo, z_hi, steps)
            optimizer_step(model, opt, objective, c1["grad_clip"])
        return Variant("batched" + (" + worker" if use_worker else ""), ca["batch"], step, source.close,
                       _cpu_clock(source))

    out = [per_window(), batched(False)]
    if worker:
        out.append(batched(True))
    return out


def record_variants(setup, cfg, sequences, frames):
    clips = core.sources.clips("train", cfg["fps"], cfg["clips"]["train_limit"] or None,
                               cfg["clips"]["frames_limit"] or None, setup.body)
    torch.manual_seed(0)
    phi = core.Stage1Model(setup).eval()

    def variant(name, batched, group):
        c = dict(cfg, stage1=dict(cfg["stage1"], batched=batched), stage2=dict(cfg["stage2"], record_group=group))

        def step():
            saved, setup.cfg = setup.cfg, c
            try:
                core.record_latents(setup, phi, clips, sequences, frames, np.random.default_rng(1))
            finally:
                setup.cfg = saved
        # per frame of one sequence: `windows` counts sequence-frames
        return Variant(name, sequences * frames, step)

    return [variant("per sequence (old)", False, 1), variant(f"groups of {sequences}", True, sequences)]


def stage2_variants(setup, cfg):
    c2 = cfg["stage2"]
    rng = np.random.default_rng(0)
    T, L = c2["sequence_frames"], setup.L
    seqs = [{"static": rng.normal(size=(T, setup.input_count)), "z": rng.normal(size=(T, L))} for _ in range(8)]
    norms = core.normalisation(setup, seqs)
    torch.manual_seed(0)
    model = core.LatentPredictor(setup, norms)
    opt = torch.optim.Adam(model.parameters(), lr=c2["lr"])
    lengths, static, target = core.padded_sequences(seqs)
    gen = torch.Generator().manual_seed(0)

    def step():
        loss = core.window_loss(model, model.z_mean, model.z_std, lengths, static, target, c2["batch"],
                                c2["window"], gen)
        opt.zero_grad()
        loss.backward()
        opt.step()
    return [Variant(f"stage 2 iteration (batch {c2['batch']} x window {c2['window']})", 1, step)]


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--preset", default="default")
    p.add_argument("--garment", default="tshirt")
    p.add_argument("--rounds", type=int, default=5, help="A/B rounds (each measures every variant once)")
    p.add_argument("--iterations", type=int, default=3, help="iterations per measurement")
    p.add_argument("--steps", type=int, default=5, help="rollout steps (5: most of a run)")
    p.add_argument("--windows", type=int, default=8, help="stage 1: windows per iteration of the batched variant")
    p.add_argument("--worker", action="store_true", help="also measure the batched variants with the data worker")
    p.add_argument("--compile", default="", help="stage 1: also measure torch.compile at these K (e.g. 1,8); "
                   "compilation happens in the warm-up and is timed")
    p.add_argument("--ddp", action="store_true", help="stage 1: also measure two processes (DDP, gloo) with "
                   "--windows/2 windows each, i.e. --windows per iteration in all")
    p.add_argument("--bf16", action="store_true", help="stage 1: also measure each batched variant with K > 1 "
                   "under stage1.autocast_bf16 (needs native bf16: AVX-512 BF16 or AMX); the DDP one also compiled "
                   "when --compile is given")
    p.add_argument("--threads", type=int, default=1, help="torch threads (the trainer's default is 1)")
    p.add_argument("--device", default="cpu", help="stage 1: the batched variants' device (e.g. cuda; the "
                   "per-window baseline stays on the CPU)")
    p.add_argument("--data-workers", type=int, default=1, help="stage 1: worker processes of the --worker variants "
                   "(stage1.data_worker; more than one pays on a many-core machine with a GPU trainer)")
    p.add_argument("--nearest", default="auto",
                   help="stage 1: stage1.nearest of the batched variants (auto: the KD-trees); a comma list "
                        "(torch,kdtree) also measures the --worker variant with each further one")
    p.add_argument("--more-windows", default="", help="stage 1: further K (e.g. 64,128) measured with --worker")
    p.add_argument("--stages", default="stage1,ablation,record,stage2")
    p.add_argument("--json", default=None, help="also write the results here")
    args = p.parse_args()
    nearest = tuple(args.nearest.split(","))
    if any(n not in ("auto", "kdtree", "torch") for n in nearest):
        p.error(f"--nearest: each of auto, kdtree, torch, not {args.nearest!r}")
    if args.more_windows and not args.worker:
        p.error("--more-windows measures the --worker variants: add --worker")
    torch.set_num_threads(args.threads)
    cfg = core.load_config(args.preset)
    setup = core.Setup(cfg, args.garment, "cpu")
    clips = core.physics_clips(cfg, setup.body)
    groups = {}
    stages = args.stages.split(",")
    if "stage1" in stages:
        if args.bf16 and not config.native_bf16(args.device):
            p.error(f"--bf16: {args.device} has no native bfloat16 (a CPU: AVX-512 BF16 or AMX)")
        device_setup = core.Setup(cfg, args.garment, args.device) if args.device != "cpu" else None
        groups["stage1"] = stage1_variants(setup, clips, cfg, args.steps, args.windows, args.worker,
                                           [int(k) for k in args.compile.split(",") if k], args.ddp, args.bf16,
                                           device_setup, args.data_workers, nearest,
                                           [int(k) for k in args.more_windows.split(",") if k])
    if "ablation" in stages:
        groups["ablation"] = ablation_variants(setup, clips, cfg, args.steps, args.worker)
    if "record" in stages:
        groups["record"] = record_variants(setup, cfg, 4, 10)
    if "stage2" in stages:
        groups["stage2"] = stage2_variants(setup, cfg)
    print(f"preset {args.preset}, {setup.N} garment vertices, {args.steps} rollout steps, torch {torch.__version__}, "
          f"{args.threads} thread(s); load before: {open('/proc/loadavg').read().strip()}", flush=True)
    warmup = {}
    for variants in groups.values():          # warm-up (first-call allocations, worker start, compilation)
        for v in variants:
            t0 = time.perf_counter()
            v.step()
            warmup[v.name] = time.perf_counter() - t0
            if "compile" in v.name:
                print(f"{v.name}: first iteration (compilation) {warmup[v.name]:.0f} s wall", flush=True)
    for r in range(args.rounds):
        for variants in groups.values():
            for v in (variants if r % 2 == 0 else variants[::-1]):
                v.measure(args.iterations)
        print(f"round {r + 1}/{args.rounds} done, load {open('/proc/loadavg').read().split()[0]}", flush=True)
    report = {"preset": args.preset, "garment_vertices": setup.N, "steps": args.steps, "rounds": args.rounds,
              "iterations": args.iterations, "threads": args.threads, "first_iteration_s": warmup,
              "load_after": open("/proc/loadavg").read().strip(), "stages": {}}
    for stage, variants in groups.items():
        base = variants[0]
        print(f"\n{stage}: {'variant':52s} {'it/s wall':>10s} {'win/s wall':>10s} {'win/s cpu':>10s} "
              f"{'x wall':>7s} {'x cpu':>7s}   (x = median over rounds of the per-window speed-up against "
              f"{base.name})")
        rows = []
        for v in variants:
            wall, cpu = statistics.median(v.wall), statistics.median(v.cpu)
            xw = statistics.median((b / base.windows) / (a / v.windows) for a, b in zip(v.wall, base.wall))
            xc = statistics.median((b / base.windows) / (a / v.windows) for a, b in zip(v.cpu, base.cpu))
            print(f"{'':8s}{v.name:52s} {1 / wall:10.3f} {v.windows / wall:10.3f} {v.windows / cpu:10.3f} "
                  f"{xw:7.2f} {xc:7.2f}")
            rows.append({"variant": v.name, "windows_per_iteration": v.windows, "iterations_per_s_wall": 1 / wall,
                         "windows_per_s_wall": v.windows / wall, "windows_per_s_cpu": v.windows / cpu,
                         "speedup_wall": xw, "speedup_cpu": xc, "wall_s": v.wall, "cpu_s": v.cpu})
        report["stages"][stage] = rows
    for variants in groups.values():
        for v in variants:
            if v.close:
                v.close()
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    os.environ.setdefault("PYTHONHASHSEED", "0")
    main()
