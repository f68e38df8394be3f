"""Shared pytest configuration: tests marked `slow` run only with PLEAT_SLOW_TESTS=1 (the default run stays short);
the shipped body as a session fixture (`body`)."""
import os

import pytest


@pytest.fixture(scope="session")
def body():
    """The shipped body (assets/body.npz); loading it fails with the command that builds it when it is missing."""
    from pleat.sim.scene import load_body
    return load_body()


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: long-running; enabled with PLEAT_SLOW_TESTS=1")


def pytest_collection_modifyitems(config, items):
    if os.environ.get("PLEAT_SLOW_TESTS") == "1":
        return
    skip = pytest.mark.skip(reason="slow test; set PLEAT_SLOW_TESTS=1 to run it")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)
