"""Shared fixtures: the repository's levels, and a level with a custom (Python-driven) model."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

import flockway

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def levels() -> Path:
    return ROOT / "levels"


def custom_ring(dir: Path, model: str = "mine", count: int = 1) -> Path:
    """The Stern ring with its autonomous car's profile driven by custom model ``model``."""
    text = (flockway.level_path("stern_ring")).read_text()
    old = 'model: WaveDamper, vehicle: "sedan", params: "drivers/wave_damper.ron"'
    assert old in text
    text = text.replace(old, f'model: Custom("{model}"), vehicle: "sedan"')
    shutil.copytree(flockway.data_dir() / "assets", dir / "assets", dirs_exist_ok=True)
    path = dir / "custom_ring.ron"
    path.write_text(text)
    return path


@pytest.fixture()
def custom_level(tmp_path: Path) -> Path:
    return custom_ring(tmp_path)
