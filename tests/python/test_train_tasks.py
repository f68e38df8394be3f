"""pleat.train.tasks' map hands each result to the caller as it finishes, and the simulated segments are kept (cached
and logged) as they come back: a run stopped half-way loses only what was still running."""
import time

import numpy as np
import pytest

from pleat.train import tasks


def _square_after(context, item):
    k, delay = item
    time.sleep(delay)
    return context * k * k


@pytest.mark.parametrize("runner", [tasks.Local(2), tasks.Serial()], ids=["local", "serial"])
def test_map_returns_in_order_and_reports_each_result_as_it_finishes(runner):
    pytest.importorskip("torch")                       # Serial runs its jobs under one_cpu (torch's thread count)
    items = [(0, 1.5), (1, 0.0), (2, 0.0)]           # the first job is the slowest
    seen = []
    out = runner.map(_square_after, 10, items, on_result=lambda k, r: seen.append((k, r)))
    assert out == [0, 10, 40]
    assert sorted(seen) == [(0, 0), (1, 10), (2, 40)]
    if runner.name == "local":                         # two workers: the quick jobs end while the slow one runs
        assert seen[-1] == (0, 0)
    else:
        assert seen == [(0, 0), (1, 10), (2, 40)]


def test_map_past_the_deadline_reports_none():
    pytest.importorskip("torch")
    seen = []
    out = tasks.Serial().map(_square_after, 1, [(3, 0.0)], deadline=time.time() - 1.0,
                             on_result=lambda k, r: seen.append((k, r)))
    assert out == [None] and seen == [(0, None)]


class _StopsAfterOne:
    """A runner that finishes the first job and then fails, as a run killed half-way does."""
    name, workers = "stops", 1

    def __init__(self):
        self.asked = []

    def map(self, fn, context, items, deadline=None, on_result=None):
        self.asked.append(len(items))
        positions = np.zeros((items[0].frames, 7, 3), np.float32)
        on_result(0, (positions, {"seconds_per_frame": 0.0}, 1.25))
        raise KeyboardInterrupt


def test_segments_simulated_before_a_stop_are_in_the_cache(tmp_path):
    pytest.importorskip("torch")
    from pleat.motion.split import available
    from pleat.train import core, simdata
    setup = core.Setup(core.load_config("tiny"), "tshirt")
    name = sorted(available("train"))[0]
    material = tuple(simdata.ga.MATERIAL_DEFAULT)
    segs = [simdata.Segment(name, "original", start, 4, tuple(np.zeros(setup.B)), material) for start in (0, 4)]
    log = []
    with pytest.raises(KeyboardInterrupt):
        simdata.simulate_segments(setup, segs, 1, tmp_path, log=log.append, runner=_StopsAfterOne())
    assert [(r["segment"], r["cache_hit"], r["cpu_s"]) for r in log] == [(0, False, 1.25)]
    # run again: the first segment comes from the cache, only the second is asked for
    again = _StopsAfterOne()
    log.clear()
    with pytest.raises(KeyboardInterrupt):
        simdata.simulate_segments(setup, segs, 1, tmp_path, log=log.append, runner=again)
    assert again.asked == [1]
    assert [(r["segment"], r["cache_hit"]) for r in log] == [(0, True), (1, False)]
