"""Shared fixtures: the real DeepMimic data lives in ../shared/deepmimic beside the checkout."""

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
DEEPMIMIC = REPO.parent / "shared" / "deepmimic"


@pytest.fixture(scope="session")
def deepmimic_dir() -> Path:
    if not DEEPMIMIC.is_dir():
        pytest.skip("../shared/deepmimic is not present")
    return DEEPMIMIC


@pytest.fixture(scope="session")
def character():
    from mjxmimic.core.character import load_character

    return load_character()
