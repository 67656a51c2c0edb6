"""Shared test set-up: an isolated cache directory per test session."""

import os
import tempfile

import pytest


@pytest.fixture(autouse=True, scope="session")
def _isolated_cache():
    """Every test session gets a fresh, empty on-disk cache (never the user's)."""
    old = os.environ.get("PULSEMAP_CACHE_DIR")
    with tempfile.TemporaryDirectory(prefix="pulsemap-test-cache-") as tmp:
        os.environ["PULSEMAP_CACHE_DIR"] = tmp
        yield tmp
    if old is None:
        os.environ.pop("PULSEMAP_CACHE_DIR", None)
    else:
        os.environ["PULSEMAP_CACHE_DIR"] = old
