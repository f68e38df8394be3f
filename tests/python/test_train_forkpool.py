"""pleat.train.forkpool: independent jobs in forked children give the results, in order, that running them one after
another gives; a failing job's error reaches the caller; seeded torch work is bit-identical either way."""
import os

import numpy as np
import pytest

from pleat.train import forkpool


def test_results_come_back_in_order_from_child_processes():
    parent = os.getpid()
    jobs = [lambda k=k: (k * k, os.getpid()) for k in range(5)]
    out = forkpool.run(jobs, workers=2)
    assert [v for v, _ in out] == [0, 1, 4, 9, 16]
    assert all(pid != parent for _, pid in out)
    assert len({pid for _, pid in out}) == 5                      # one child per job
    assert all(pid == parent for _, pid in forkpool.run(jobs, workers=1))


def test_a_failing_job_raises_with_its_traceback():
    def bad():
        raise ValueError("no such garment")
    with pytest.raises(RuntimeError, match="no such garment"):
        forkpool.run([lambda: 1, bad, lambda: 3], workers=2)


def test_seeded_torch_training_is_bit_identical_in_a_child():
    torch = pytest.importorskip("torch")

    def job(seed):
        def fit():
            torch.set_num_threads(1)
            torch.manual_seed(seed)
            net = torch.nn.Sequential(torch.nn.Linear(8, 32), torch.nn.ReLU(), torch.nn.Linear(32, 4))
            opt = torch.optim.Adam(net.parameters(), 1e-2)
            x = torch.randn(64, 8)
            for _ in range(20):
                opt.zero_grad()
                loss = (net(x) - x[:, :4]).square().mean()
                loss.backward()
                opt.step()
            return [p.detach().numpy().copy() for p in net.parameters()]
        return fit
    here = forkpool.run([job(1), job(2)], workers=1)
    there = forkpool.run([job(1), job(2)], workers=2)
    for a, b in zip(here, there):
        assert all(np.array_equal(x, y) for x, y in zip(a, b))
    assert not np.array_equal(here[0][0], here[1][0])             # the seeds matter


def test_a_jobs_budget_is_its_wave_of_the_whole():
    assert forkpool.deadline(0.0, None, 0, 4, 2) is None
    assert [forkpool.deadline(0.0, 60.0, k, 4, 2) for k in range(4)] == [30.0, 30.0, 60.0, 60.0]
    assert [forkpool.deadline(0.0, 60.0, k, 3, 1) for k in range(3)] == [20.0, 40.0, 60.0]
    assert [forkpool.deadline(0.0, 60.0, k, 3, 2) for k in range(3)] == [30.0, 30.0, 60.0]
