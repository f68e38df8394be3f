"""An Acclaim skeleton is refused, quickly and with a clear message, when its bones nest deeper than a BVH hierarchy may
(MAX_BVH_DEPTH), and a deep but legal chain is ordered parents-first in linear time. A malformed or hostile .asf must
not keep a tool busy for minutes: each load here runs under an alarm, so a slow ordering fails instead of hanging."""
import signal
import time
from contextlib import contextmanager

import numpy as np
import pytest

from pleat.motion.loaders import MAX_BVH_DEPTH, MotionFileError, read_amc
from synthetic_asf import asf_text


@contextmanager
def _deadline(seconds):
    def expired(signum, frame):
        raise TimeoutError(f"the load took longer than {seconds} s")
    previous = signal.signal(signal.SIGALRM, expired)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def _chain(tmp_path, depth):
    """An .asf whose bones b0 … b{depth-1} hang one below the other under the root, and a two-frame .amc for it."""
    bones = [(f"b{i}", "0 1 0", 1, "0 0 0") for i in range(depth)]
    links = ["root b0"] + [f"b{i} b{i + 1}" for i in range(depth - 1)]
    (tmp_path / "m.asf").write_text(asf_text(bones, links))
    frames = []
    for t in range(2):
        frames += [str(t + 1), "root 0 0 0 0 0 0"] + [f"b{i} 0 0 0" for i in range(depth)]
    (tmp_path / "m.amc").write_text(":FULLY-SPECIFIED\n:DEGREES\n" + "\n".join(frames) + "\n")
    return tmp_path / "m.amc"


def test_a_2000_deep_asf_is_refused_in_well_under_a_second(tmp_path):
    amc = _chain(tmp_path, 2000)
    start = time.perf_counter()
    with _deadline(5), pytest.raises(MotionFileError, match=f"nest more than {MAX_BVH_DEPTH} deep"):
        read_amc(amc)
    assert time.perf_counter() - start < 1.0


def test_a_chain_at_the_depth_limit_loads_parents_first(tmp_path):
    depth = MAX_BVH_DEPTH - 1  # with the root, MAX_BVH_DEPTH joints nested: as deep as a BVH may go
    with _deadline(20):
        clip = read_amc(_chain(tmp_path, depth))
    assert clip.names == ["root"] + [f"b{i}" for i in range(depth)]
    assert np.array_equal(clip.parents, np.arange(-1, depth))
    with _deadline(20), pytest.raises(MotionFileError, match="nest more than"):
        read_amc(_chain(tmp_path, depth + 1))
