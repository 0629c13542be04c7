"""Shared fixtures. ``febio_baseline``: the real FEBio 4 run of ../shared/febio/baseline, or a skip
that names the missing folder when the clone has no ../shared beside it."""

from __future__ import annotations

from pathlib import Path

import pytest

SHARED = Path(__file__).resolve().parents[2] / "shared"
#: The real FEBio 4 run of the paper's baseline (tests that need it skip, naming it, when absent).
FEBIO_BASELINE = SHARED / "febio" / "baseline"


@pytest.fixture(scope="session")
def febio_baseline() -> Path:
    """The folder of the shared FEBio baseline run (baseline.feb, .log, .npz, .json)."""
    folder = FEBIO_BASELINE
    if not (folder / "baseline.feb").is_file() or not (folder / "baseline.npz").is_file():
        pytest.skip(f"shared FEBio data absent: {folder} (clone with ../shared beside it to run this test)")
    return folder
