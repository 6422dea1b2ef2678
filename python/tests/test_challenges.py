"""Challenges: levels with a score and medals, played from Python — by a Python driver, by a
built-in model named as a string — and a Python driver against the same driver in Rust."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import flockway

ROOT = Path(__file__).resolve().parents[2]


class GapKeeper:
    """The docs' driver: the speed that closes the gap beyond 2 m + 1.5 s of its own speed in
    2 s, up to the 30 km/h limit of the ring."""

    def __init__(self, gap_s: float = 1.5, limit_mps: float = 30 / 3.6) -> None:
        self.gap_s, self.limit_mps = gap_s, limit_mps

    def decide(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        v = obs["speed_mps"]
        lead = np.where(np.isfinite(obs["leader_speed_mps"]), obs["leader_speed_mps"],
                        self.limit_mps)
        want = lead + (obs["gap_m"] - 2.0 - self.gap_s * v) / 2.0
        return np.clip(want, 0.0, self.limit_mps)


def rust_driver() -> Path:
    """The Rust gap keeper (examples/challenge_driver.rs), built by cargo if need be."""
    if shutil.which("cargo") is None:
        pytest.skip("the Rust driver is built from a checkout with cargo")
    # `--workspace`: the features `cargo test --workspace` built it with, so after the README's
    # test command this reuses that build instead of compiling the workspace again.
    subprocess.run(
        ["cargo", "build", "--quiet", "--workspace", "--example", "challenge_driver"],
        cwd=ROOT, check=True,
    )
    return ROOT / "target" / "debug" / "examples" / "challenge_driver"


def test_the_shipped_challenges_are_listed_and_carry_a_score() -> None:
    assert flockway.challenges() == ["challenges/damp_the_wave", "challenges/merge_smoothly"]
    summary = flockway.run("challenges/damp_the_wave", drivers={"controller": GapKeeper()},
                           seed=5, seconds=160.0)
    assert isinstance(summary["score"], float)
    assert summary["medal"] in (None, "bronze", "silver", "gold")
    m = summary["metrics"]
    assert summary["score"] == pytest.approx(
        m["mean_speed_kmh.human"] - m["speed_std_kmh.human"] - 5 * m["collisions"])


def test_a_python_driver_and_the_same_driver_in_rust_drive_bit_for_bit_alike(
    tmp_path: Path,
) -> None:
    level = ROOT / "levels" / "challenges" / "damp_the_wave.ron"
    py_csv, rs_csv = tmp_path / "python.csv", tmp_path / "rust.csv"
    py = flockway.run(level, drivers={"controller": GapKeeper()}, seed=7, seconds=60.0,
                      csv=py_csv)
    out = subprocess.run(
        [str(rust_driver()), str(level), "--seed", "7", "--seconds", "60", "--csv", str(rs_csv)],
        capture_output=True, text=True, check=True,
    )
    rs = json.loads(out.stdout)
    # The same law on the same figures (f64 in both), the same tick: the same run.
    assert py_csv.read_bytes() == rs_csv.read_bytes()
    assert py["metrics"] == rs["metrics"]
    assert py["score"] == rs["score"]
    # And it is a driver: it follows its leader, unlike the untold car.
    untold_csv = tmp_path / "untold.csv"
    flockway.run(level, seed=7, seconds=60.0, csv=untold_csv)
    assert untold_csv.read_bytes() != py_csv.read_bytes()


def test_a_built_in_model_named_as_a_string_plays_the_challenge() -> None:
    damper = flockway.run("challenges/damp_the_wave", drivers={"controller": "WaveDamper"},
                          seed=13)
    plain = flockway.run("challenges/damp_the_wave", drivers={"controller": "FlockLanes"},
                         seed=13)
    assert damper["medal"] == "silver", damper["score"]
    assert plain["medal"] is None, plain["score"]
    with pytest.raises(ValueError, match="not a built-in driver model"):
        flockway.Sim("challenges/damp_the_wave", drivers={"controller": "Wizard"})
    with pytest.raises(ValueError, match="no driver profile or custom model `pilot`"):
        flockway.Sim("challenges/damp_the_wave", drivers={"pilot": "Idm"})


class Cruise:
    """The docs' challenge driver: a steady speed, slowing only when the gap closes."""

    def __init__(self, speed_mps: float = 2.8, min_gap_m: float = 4.0) -> None:
        self.speed, self.min_gap = speed_mps, min_gap_m

    def decide(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        room = obs["leader_speed_mps"] + (obs["gap_m"] - self.min_gap) / 2.0
        return np.clip(np.minimum(self.speed, room), 0.0, self.speed)


def test_the_docs_cruise_beats_the_wave_damper_for_gold() -> None:
    # The docs quote seeds 1-5; this is another.
    cruise = flockway.run("challenges/damp_the_wave", drivers={"controller": Cruise()}, seed=4)
    damper = flockway.run("challenges/damp_the_wave", drivers={"controller": "WaveDamper"},
                          seed=4)
    assert cruise["medal"] == "gold", cruise["score"]
    assert cruise["score"] > damper["score"]


def test_a_merger_told_only_its_speed_still_merges_where_its_lane_ends() -> None:
    class Steady:
        def decide(self, obs):
            return np.full(len(obs["id"]), 20.0)

    s = flockway.Sim("challenges/merge_smoothly", seed=2, drivers={"merger": Steady()})
    through: set[int] = set()
    for _ in range(150):
        s.step(120)
        v = s.vehicles()
        mine = (v["model"] == "Custom(merger)") & (v["road"] == "downstream")
        through.update(int(i) for i in v["id"][mine])
        stuck = (v["road"] == "merge") & (v["lane"] == 0) & (v["speed_mps"] < 1.0)
        assert not stuck.any(), f"a car waits at the end of the acceleration lane at {s.time_s} s"
    # The ramp's cars got through the acceleration lane onto the motorway, none sent elsewhere.
    assert len(through) >= 10
    assert s.summary()["metrics"]["missed_exits"] == 0
