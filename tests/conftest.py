"""Shared test fixtures: paths to the repository and to ../shared."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
PATROLLING_SIM_MAPS = SHARED / "maps" / "patrolling_sim"


@pytest.fixture(scope="session")
def shared_maps() -> Path:
    if not PATROLLING_SIM_MAPS.is_dir():
        pytest.skip(f"reference maps not found at {PATROLLING_SIM_MAPS}")
    return PATROLLING_SIM_MAPS
