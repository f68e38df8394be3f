"""Distributed data parallel (torchrun): rank and world from the environment, the device of a rank, wrapping a
model, and stopping every rank at the same iteration."""
import os

import torch


def dist_info():
    world = int(os.environ.get("WORLD_SIZE", "1"))
    rank = int(os.environ.get("RANK", "0"))
    if world > 1 and not torch.distributed.is_initialized():
        backend = "nccl" if torch.cuda.is_available() else "gloo"
        torch.distributed.init_process_group(backend)
        if torch.cuda.is_available():
            torch.cuda.set_device(int(os.environ.get("LOCAL_RANK", "0")))
    return rank, world


def wrap_ddp(module, world, device):
    if world > 1:
        return torch.nn.parallel.DistributedDataParallel(
            module, device_ids=[device.index] if device.type == "cuda" else None)
    return module


def unwrap(module):
    return module.module if hasattr(module, "module") else module


def stop_everywhere(world, stop, device):
    """Under DDP every rank must stop at the same iteration: rank 0's clock decides."""
    if world <= 1:
        return stop
    flag = torch.tensor([1.0 if stop else 0.0], device=device)
    torch.distributed.broadcast(flag, 0)
    return bool(flag.item())


def device_for(name, rank):
    if name == "auto":
        name = "cuda" if torch.cuda.is_available() else "cpu"
    if name == "cuda":
        return torch.device("cuda", int(os.environ.get("LOCAL_RANK", rank)))
    return torch.device("cpu")
