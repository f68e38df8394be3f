"""A training run's bookkeeping: its config and sources written once, the metrics log, checkpoints (written
atomically) and resume, and the hardware it ran on."""
import json
import os
import platform
import time
from pathlib import Path

import torch

from pleat import fileio
from pleat.train import sources


class Run:
    def __init__(self, out, stage, cfg, rank):
        self.out, self.stage, self.rank = Path(out), stage, rank
        self.t0 = time.time()
        if rank == 0:
            self.out.mkdir(parents=True, exist_ok=True)
            fileio.write_text(self.out / f"config_{stage}.json", json.dumps(
                {"config": cfg, "sources": sources.used, "hardware": hardware()}, indent=2, default=str))
            self.metrics = open(self.out / f"metrics_{stage}.jsonl", "a")

    def log(self, record):
        if self.rank == 0:
            record = {"stage": self.stage, "time_s": round(time.time() - self.t0, 3), **record}
            self.metrics.write(json.dumps(record) + "\n")
            self.metrics.flush()

    def checkpoint(self, state):
        if self.rank == 0:
            fileio.save_torch(self.out / f"{self.stage}.pt", state)

    def resume(self):
        p = self.out / f"{self.stage}.pt"
        return torch.load(p, weights_only=False) if p.exists() else None

    def restore(self, model, optimizer, elapsed_s=0.0):
        """Continue from this stage's checkpoint, if there is one: model and optimizer state loaded. Returns (the
        iteration to start at, the wall time already spent), (0, elapsed_s) without a checkpoint."""
        state = self.resume()
        if state is None:
            return 0, elapsed_s
        model.load_state_dict(state["model"])
        optimizer.load_state_dict(state["optimizer"])
        return state["iteration"], state.get("elapsed_s", elapsed_s)

    def log_stopped(self, iteration, max_minutes, budget):
        """The record a loop leaves when its time budget (--max-minutes) ends it."""
        self.log({"iteration": iteration, "stopped": "time budget", "max_minutes": max_minutes,
                  "elapsed_s": budget.elapsed()})


def hardware():
    info = {"machine": platform.machine(), "processor": platform.processor() or platform.machine(),
            "cpu_count": os.cpu_count(), "torch": torch.__version__, "threads": torch.get_num_threads()}
    if torch.cuda.is_available():
        info["gpu"] = torch.cuda.get_device_name(0)
    return info


def _rng_state():
    return {"torch": torch.get_rng_state()}
