"""Drivers written in Python: a level's Custom profile driven by decide(obs)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import flockway


class GapKeeper:
    """Holds a time gap to its leader: the speed that closes the excess gap in 2 s."""

    def __init__(self, gap_s: float = 1.5, limit_mps: float = 30 / 3.6) -> None:
        self.gap_s = gap_s
        self.limit_mps = limit_mps
        self.calls = 0

    def decide(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        self.calls += 1
        v = obs["speed_mps"]
        lead = np.where(np.isfinite(obs["leader_speed_mps"]), obs["leader_speed_mps"],
                        self.limit_mps)
        want = lead + (obs["gap_m"] - 2.0 - self.gap_s * v) / 2.0
        return np.clip(want, 0.0, self.limit_mps)


def test_a_python_driver_drives_its_custom_profile_every_step(custom_level: Path) -> None:
    keeper = GapKeeper()
    s = flockway.Sim(custom_level, seed=1, drivers={"mine": keeper})
    s.step(120 * 30)
    assert keeper.calls == 120 * 30
    v = s.vehicles()
    mine = v["model"] == "Custom(mine)"
    assert mine.sum() == 1
    assert (v["profile"][mine] == "autonomous").all()
    summary = s.summary()
    assert summary["metrics"]["collisions"] == 0.0


def test_run_with_drivers_is_deterministic_and_returns_the_summary(custom_level: Path) -> None:
    a = flockway.run(custom_level, drivers={"mine": GapKeeper()}, seed=4, seconds=20.0)
    b = flockway.run(custom_level, drivers={"mine": GapKeeper()}, seed=4, seconds=20.0)
    assert a["metrics"] == b["metrics"]
    assert a["sim_seconds"] == 20.0


def test_a_driver_may_return_controls_or_targets_with_lanes(custom_level: Path) -> None:
    class Brake:
        def decide(self, obs):
            return {"throttle": np.zeros(len(obs["id"])), "steering": 0.0, "handbrake": True}

    s = flockway.Sim(custom_level, seed=1, drivers={"mine": Brake()})
    s.step(600)
    v = s.vehicles()
    assert abs(v["speed_mps"][v["model"] == "Custom(mine)"][0]) < 0.1

    class Bad:
        def decide(self, obs):
            return {"speed": 3.0}

    s = flockway.Sim(custom_level, seed=1, drivers={"mine": Bad()})
    with pytest.raises(ValueError, match="speed_mps"):
        s.step(1)
    with pytest.raises(TypeError, match="decide"):
        flockway.Sim(custom_level, drivers={"mine": object()})
