"""Shared pytest configuration: tests marked `slow` run only with PLEAT_SLOW_TESTS=1 (the default run stays short)."""
import os

import pytest


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: long-running; enabled with PLEAT_SLOW_TESTS=1")


def pytest_collection_modifyitems(config, items):
    if os.environ.get("PLEAT_SLOW_TESTS") == "1":
        return
    skip = pytest.mark.skip(reason="slow test; set PLEAT_SLOW_TESTS=1 to run it")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)
