"""Shared pytest configuration.

``require(name)`` imports an optional dependency. Locally it skips the test when
the dependency is missing; under ``LABKIT_REQUIRE_ALL=1`` (set by ``make test``,
hence CI) a missing dependency is an error, so CI never silently skips.
"""

import importlib
import os

import matplotlib
import pytest

matplotlib.use("Agg")

REQUIRE_ALL = os.environ.get("LABKIT_REQUIRE_ALL") == "1"


def require(name):
    """Import module ``name`` or skip (locally) / fail (CI)."""
    if REQUIRE_ALL:
        return importlib.import_module(name)
    return pytest.importorskip(name)


@pytest.fixture
def rng():
    """A seeded random generator (same numbers every run)."""
    import numpy as np

    return np.random.default_rng(12345)
