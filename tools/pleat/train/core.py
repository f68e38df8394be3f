"""The two training stages, the ablation and packing (paper sections 3.2, 3.3, 4.1, 4.3), in one namespace.

Stage 1 trains Φ (Encode–Process–Convolve–Decode + blend shapes) on the physics losses of equation 4 with no ground
truth: each iteration samples a clip window, β ~ U(−β_max, β_max) and a material in the paper's ranges, starts the
garment from the LBS of the shaped template on the first three frames, and rolls Φ autoregressively for 1 → 5 steps
(one more every `rollout_every` of the run), back-propagating through the whole rollout.
Stage 2 freezes Φ, records its latents on rollouts, and fits f_LP on X_c (built by the same function the runtime
reference uses) with MSE, feeding f_LP its own previous predictions inside a window (Z_0 = 0 at sequence starts).
The ablation trains f_LP → f_dec → D directly on the stage-1 losses.

The code lives in one module per concern; this module re-exports their names so that `pleat.train.core.X` keeps
working for pleat-train, pleat-eval, distillation, simulator supervision and the tests:

    config      the preset, the loss terms and their weights over the run, rollout length, optimiser, threads, budget
    ddp         ranks and devices under torchrun, DDP wrapping, stopping every rank together
    data        Setup (garment + body, once), window kinematics, Window (rollout state, Φ's features, losses), sampling
    models      Stage1Model (Φ + inference block), LatentPredictor (f_LP), AblationModel
    run         the metrics log, checkpoints and resume, hardware
    stage1, stage2, ablation   the three training loops, their validation and what they record
    packing     a run → a .pleat asset
    inference   the inference block in torch over a clip
    sources     where the body, garment, motion and energies come from (no stand-ins)
"""
from pleat.train import sources  # noqa: F401 (core.sources: what a run read)
from pleat.train.ablation import pose_statistics, train_ablation
from pleat.train.config import (LOSS_TERMS, Budget, batched_path, lerp, load_config, loss_weights, make_optimizer,
                                rollout_steps, run_fraction, set_threads, weighted)
from pleat.train.data import Setup, Window, physics_clips, sample_window, to_t, vertex_normals
from pleat.train.ddp import device_for, dist_info, stop_everywhere, unwrap, wrap_ddp
from pleat.train.inference import torch_inference
from pleat.train.models import AblationModel, LatentPredictor, Stage1Model
from pleat.train.packing import final_losses, network_weights, pack
from pleat.train.run import Run, hardware
from pleat.train.stage1 import lbs_scale, load_stage1, rollout_loss, train_stage1, validate_stage1
from pleat.train.stage2 import (normalisation, padded_sequences, record_latents, train_stage2, validate_stage2,
                                window_loss)

__all__ = ["AblationModel", "Budget", "LOSS_TERMS", "LatentPredictor", "Run", "Setup", "Stage1Model", "Window",
           "batched_path", "device_for", "dist_info", "final_losses", "hardware", "lbs_scale", "lerp", "load_config",
           "load_stage1", "loss_weights", "make_optimizer", "network_weights", "normalisation", "pack",
           "padded_sequences", "physics_clips", "pose_statistics", "record_latents", "rollout_loss", "rollout_steps",
           "run_fraction", "sample_window", "set_threads", "sources", "stop_everywhere", "to_t", "torch_inference",
           "train_ablation", "train_stage1", "train_stage2", "unwrap", "validate_stage1", "validate_stage2",
           "vertex_normals", "weighted", "window_loss", "wrap_ddp"]
