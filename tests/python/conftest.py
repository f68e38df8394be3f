"""Shared pytest configuration: tests marked `slow` run only with PLEAT_SLOW_TESTS=1 (the default run stays short);
the shipped body as a session fixture (`body`); the tiny training preset with its setup and physics clips
(`tiny_physics`); the C runtime's Python binding (`c_runtime`); a script imported by its path (`load_script`)."""
import os

import pytest


@pytest.fixture(scope="session")
def body():
    """The shipped body (assets/body.npz); loading it fails with the command that builds it when it is missing."""
    from pleat.sim.scene import load_body
    return load_body()


@pytest.fixture(scope="module")
def tiny_physics():
    """(cfg, setup, clips) of the tiny preset: the T-shirt on the CPU with stage 1's physics clips, one torch thread
    (so the numbers do not depend on the machine's core count). Skips without PyTorch."""
    torch = pytest.importorskip("torch", reason="PyTorch not installed (pip install 'pleat-tools[train]')")
    from pleat.train import core
    torch.set_num_threads(1)
    cfg = core.load_config("tiny")
    setup = core.Setup(cfg, "tshirt", "cpu")
    return cfg, setup, core.physics_clips(cfg, setup.body)


@pytest.fixture(scope="module")
def c_runtime():
    """pleat.runtime, the C library's binding; skips where libpleat.so is not built."""
    runtime = pytest.importorskip("pleat.runtime")
    if runtime.find_library() is None:
        pytest.skip("libpleat.so not built (set PLEAT_BUILD_DIR or PLEAT_LIBRARY)")
    return runtime


@pytest.fixture(scope="session")
def load_script():
    """A function that imports one of the repository's scripts (not a package module) by its path from the
    repository root, e.g. load_script("scripts/docs-numbers.py")."""
    import importlib.util

    from pleat import REPO_ROOT

    def load(relpath):
        path = REPO_ROOT / relpath
        spec = importlib.util.spec_from_file_location(path.stem.replace("-", "_"), path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module
    return load


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: long-running; enabled with PLEAT_SLOW_TESTS=1")


def pytest_collection_modifyitems(config, items):
    if os.environ.get("PLEAT_SLOW_TESTS") == "1":
        return
    skip = pytest.mark.skip(reason="slow test; set PLEAT_SLOW_TESTS=1 to run it")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)
