"""The examples and benchmarks that CI does not run (Ray Tune, RLlib with torch): they compile,
and their ``--help`` needs none of their heavy imports."""

from __future__ import annotations

import py_compile
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = sorted((ROOT / "python" / "examples").glob("*.py")) + sorted(
    (ROOT / "python" / "bench").glob("*.py"))


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_the_script_compiles(script: Path) -> None:
    py_compile.compile(str(script), doraise=True)


def test_the_rllib_example_describes_itself_without_ray_or_torch() -> None:
    script = ROOT / "python" / "examples" / "train_ring_wave_rllib.py"
    out = subprocess.run([sys.executable, str(script), "--help"], capture_output=True,
                         text=True, check=True)
    assert "--iterations" in out.stdout and "RLlib" in out.stdout
