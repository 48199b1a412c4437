"""Shared fixtures of the Python tests (run by ctest: python/CMakeLists.txt sets PYTHONPATH to
the build tree's package, RADLAB_BINARY to the command line and RADLAB_CACHE_DIR to the suite's
cache)."""

import os

import pytest

import radlab


@pytest.fixture(scope="session")
def radlab_binary():
    path = os.environ.get("RADLAB_BINARY")
    if not path:
        pytest.fail("RADLAB_BINARY is not set (ctest sets it to build/cli/radlab)")
    return path


@pytest.fixture(scope="session")
def cornell4():
    return radlab.load("builtin:cornell", subdiv=4)


@pytest.fixture(scope="session")
def cube4():
    return radlab.load("builtin:cube", subdiv=4)
