"""Shared test fixtures.

Real recordings are read from ``../shared/real-data/`` beside the checkout
and never copied into the repository; tests that need them skip cleanly
where that folder is absent.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REAL_DATA = Path(
    os.environ.get("GYROCOMP_REAL_DATA", Path(__file__).resolve().parents[1].parent / "shared" / "real-data")
)


@pytest.fixture
def real_data():
    """Return the path of a folder of ``../shared/real-data``, or skip the test."""

    def locate(name: str) -> Path:
        folder = REAL_DATA / name
        if not folder.is_dir():
            pytest.skip(f"real data {name!r} not found under {REAL_DATA}")
        return folder

    return locate
