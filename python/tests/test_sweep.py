"""Sweeps on a local Ray of two workers, against `flockway test`."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

ray = pytest.importorskip("ray")

import flockway  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


def cli() -> Path:
    """The `flockway` binary built last (`cargo test` builds the debug one)."""
    built = [ROOT / "target" / p / "flockway" for p in ("debug", "release")]
    built = [exe for exe in built if exe.exists()]
    if not built:
        pytest.skip("no flockway binary built (cargo build) to compare with")
    return max(built, key=lambda exe: exe.stat().st_mtime)


@pytest.fixture(scope="module")
def local_ray():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, configure_logging=False)
    yield
    ray.shutdown()


def test_a_sweep_measures_what_flockway_test_measures(local_ray, tmp_path: Path) -> None:
    level = ROOT / "levels" / "sugiyama_ring.ron"
    frame = flockway.sweep([str(level)], seeds=[1, 2, 3])
    assert list(frame["seed"]) == [1, 2, 3]
    assert list(frame["level"]) == ["sugiyama_ring"] * 3
    out = tmp_path / "summaries.jsonl"
    subprocess.run(
        [str(cli()), "test", str(level), "--seed-list", "1,2,3", "--summaries", str(out)],
        check=True, capture_output=True,
    )
    summaries = [json.loads(line) for line in out.read_text().splitlines()]
    assert [s["seed"] for s in summaries] == [1, 2, 3]
    assert list(frame["wave_speed_kmh"]) == [s["wave_speed_kmh"] for s in summaries]
    assert list(frame["speed_std_kmh.human"]) == [
        s["metrics"]["speed_std_kmh.human"] for s in summaries
    ]


def test_a_grid_runs_every_combination_with_its_overrides(local_ray) -> None:
    frame = flockway.sweep(
        ["sugiyama_ring"], seeds=[1], seconds=170.0,
        grid={"human.reaction_time_s": [0.4, 0.9], "human.flock.target_speed_kmh": [20.0, 30.0]},
    )
    assert len(frame) == 4
    assert list(frame["override.human.reaction_time_s"]) == [0.4, 0.4, 0.9, 0.9]
    assert list(frame["override.human.flock.target_speed_kmh"]) == [20.0, 30.0, 20.0, 30.0]
    slow = frame[frame["override.human.flock.target_speed_kmh"] == 20.0]["mean_speed_kmh"]
    fast = frame[frame["override.human.flock.target_speed_kmh"] == 30.0]["mean_speed_kmh"]
    # The ring's statistics start at 150 s.
    assert slow.max() < fast.min()
