"""Snapshots: a restored run is byte for byte the run it came from, a clone is independent, a
Python driver's decisions are kept, and a pickled environment gives the same episode in another
process."""

from __future__ import annotations

import copy
import multiprocessing
import pickle
import shutil
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import flockway


def _calls(sim: flockway.Sim) -> None:
    """A controller's calls between steps: signals, a spawn on a route, a vehicle taken over."""
    sim.step(120 * 15)
    sim.set_phase("A0", 2)
    sim.step(240)
    new = sim.spawn("left0A0", 20.0, "autonomous", speed_mps=8.0, route=["left0A0", "A0B0"])
    sim.step(120)
    sim.set_target([new], 5.0)
    sim.vehicles()  # reads are not part of a snapshot and change nothing
    sim.set_signal_state("B1", sim.signals()[3]["state"].replace("G", "r"), amber_s=3.0)
    sim.step(600)


def test_a_restored_run_writes_the_same_bytes_as_one_never_snapshotted(tmp_path: Path) -> None:
    whole = flockway.Sim("signal_grid", seed=13, csv=tmp_path / "whole.csv")
    _calls(whole)
    whole.step(120 * 20)

    first = flockway.Sim("signal_grid", seed=13, csv=False)
    _calls(first)
    state = first.snapshot()
    assert isinstance(state, bytes)
    first.step(5)  # the snapshot holds its moment: later steps are not in it
    # Restored into a Sim of another seed, writing its own CSV: the run from the snapshot on.
    other = flockway.Sim("signal_grid", seed=2, csv=tmp_path / "restored.csv")
    other.step(30)
    other.restore(state)
    assert other.time_s == pytest.approx(first.time_s - 5 / 120, abs=1e-12)
    other.step(120 * 20)
    for suffix in ("csv", "signals.csv"):
        a = (tmp_path / f"whole.{suffix}").read_bytes()
        b = (tmp_path / f"restored.{suffix}").read_bytes()
        assert len(a) > 1000 and a == b, suffix
    assert whole.summary()["metrics"] == other.summary()["metrics"]


def test_detectors_and_signals_come_back_with_the_run() -> None:
    a = flockway.Sim("signal_queue", seed=6, csv=False)
    a.step(120 * 70)
    b = flockway.Sim("signal_queue", seed=6, csv=False)
    b.restore(a.snapshot())
    for sim in (a, b):
        sim.step(120 * 55)
    for key, col in a.detectors().items():
        np.testing.assert_array_equal(col, b.detectors()[key])
    assert a.detector_log().equals(b.detector_log())
    assert a.signals() == b.signals()


def test_a_clone_is_independent_and_runs_on_as_the_original_would() -> None:
    sim = flockway.Sim("dense_road", seed=4, csv=False)
    sim.step(120 * 10)
    twin = sim.clone()
    deep = copy.deepcopy(sim)
    before = sim.vehicles()
    twin.despawn(twin.vehicles()["id"][:5])
    twin.step(120)
    after = sim.vehicles()
    np.testing.assert_array_equal(before["x_m"], after["x_m"])  # the original did not move
    for s in (sim, deep):
        s.step(120)
    for key in ("id", "x_m", "y_m", "speed_mps", "throttle"):
        np.testing.assert_array_equal(sim.vehicles()[key], deep.vehicles()[key])
    assert len(twin.vehicles()["id"]) != len(sim.vehicles()["id"])
    # Without telemetry, the copies write none; with it, each its own temporary file.
    assert twin.csv is None and deep.csv is None
    writing = flockway.Sim("dense_road", seed=4)
    writing.step(240)
    copy_ = writing.clone()
    assert copy_.csv is not None and copy_.csv != writing.csv
    copy_.step(120)
    writing.step(120)
    assert copy_.csv.read_bytes() == writing.csv.read_bytes()


class Counting:
    """A follower that holds 12 m/s, counting how often it is asked."""

    def __init__(self) -> None:
        self.asked = 0

    def decide(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        self.asked += 1
        return np.full(len(obs["id"]), 12.0)


def test_a_python_drivers_decisions_are_replayed_not_asked_again(tmp_path: Path) -> None:
    from conftest import custom_ring

    level = custom_ring(tmp_path)
    driver = Counting()
    sim = flockway.Sim(level, seed=3, drivers={"mine": driver}, csv=False)
    sim.step(240)
    assert driver.asked == 240
    other_driver = Counting()
    other = flockway.Sim(level, seed=3, drivers={"mine": other_driver}, csv=False)
    other.restore(sim.snapshot())
    assert other_driver.asked == 0
    for s in (sim, other):
        s.step(120)
    assert other_driver.asked == 120
    for key in ("x_m", "speed_mps", "throttle"):
        np.testing.assert_array_equal(sim.vehicles()[key], other.vehicles()[key])


def test_what_is_not_a_snapshot_of_this_level_is_refused(tmp_path: Path) -> None:
    sim = flockway.Sim("dense_road", seed=1, csv=False)
    with pytest.raises(ValueError, match="no signalised junction"):
        sim.set_phase("nowhere", 0)  # refused: changes nothing, and is not in the snapshot
    sim.step(10)
    state = sim.snapshot()
    with pytest.raises(ValueError, match="not a Flockway snapshot"):
        sim.restore(b"not a snapshot")
    with pytest.raises(ValueError, match="not a Flockway snapshot"):
        sim.restore(pickle.dumps({"something": 1}))
    with pytest.raises(ValueError, match="format 99"):
        sim.restore(pickle.dumps({**pickle.loads(state), "format": 99}))
    # A level file that changed since cannot give the same run.
    copied = tmp_path / "dense_road.ron"
    shutil.copy(flockway.level_path("dense_road"), copied)
    shutil.copytree(flockway.data_dir() / "assets", tmp_path / "assets")
    mine = flockway.Sim(copied, seed=1, csv=False)
    mine.step(10)
    saved = mine.snapshot()
    copied.write_text(copied.read_text().replace("duration_s: 120.0", "duration_s: 100.0"))
    with pytest.raises(ValueError, match="changed since the snapshot"):
        mine.restore(saved)
    assert mine.time_s == pytest.approx(10 / 120)  # unchanged by the refusal
    sim.restore(state)
    assert sim.time_s == pytest.approx(10 / 120)


def _episode(env: Any, actions: list[Any]) -> tuple[list[np.ndarray], list[float]]:
    obs, rewards = [], []
    for a in actions:
        o, r, terminated, truncated, _ = env.step(a)
        obs.append(np.asarray(o))
        rewards.append(float(r))
        if terminated or truncated:
            break
    return obs, rewards


def _episode_from_bytes(data: bytes, actions: list[Any]) -> tuple[list[np.ndarray], list[float]]:
    return _episode(pickle.loads(data), actions)


@pytest.mark.parametrize(
    ("name", "kwargs"),
    [
        ("flockway/Level-v0", {"level": "dense_road", "warmup_s": 20.0}),
        ("flockway/SignalControl-v0", {"level": "signal_grid", "warmup_s": 20.0}),
    ],
)
def test_a_pickled_environment_gives_the_same_episode_in_another_process(
    name: str, kwargs: dict[str, Any]
) -> None:
    env = gym.make(name, **kwargs)
    env.reset(seed=21)
    env.action_space.seed(21)
    actions = [env.action_space.sample() for _ in range(25)]
    env.step(actions[0])
    data = pickle.dumps(env)
    with multiprocessing.get_context("spawn").Pool(1) as pool:
        there = pool.apply(_episode_from_bytes, (data, actions[1:]))
    here = _episode(env, actions[1:])
    assert len(here[1]) == len(there[1]) == 24
    assert here[1] == there[1]
    for a, b in zip(here[0], there[0]):
        np.testing.assert_array_equal(a, b)


def test_the_pettingzoo_environments_pickle_mid_episode() -> None:
    from flockway import multi

    for env in (multi.parallel_env(level="dense_road"),
                multi.signal_parallel_env(level="signal_grid")):
        env.reset(seed=2)
        for _ in range(3):
            env.step({a: env.action_space(a).sample() for a in env.agents})
        copy_ = pickle.loads(pickle.dumps(env))
        assert copy_.agents == env.agents
        for _ in range(3):
            actions = {a: env.action_space(a).sample() for a in env.agents}
            here, there = env.step(actions), copy_.step(actions)
            assert here[1] == there[1]
            for agent in here[0]:
                np.testing.assert_array_equal(here[0][agent], there[0][agent])


def test_a_sim_made_without_snapshots_keeps_no_calls() -> None:
    sim = flockway.Sim("dense_road", seed=1, csv=False, snapshots=False)
    sim.step(120)
    sim.set_target(sim.vehicles()["id"][:2], 5.0)
    sim.step(10)
    with pytest.raises(RuntimeError, match="snapshots=False"):
        sim.snapshot()
    with pytest.raises(RuntimeError, match="snapshots=False"):
        pickle.dumps(sim)
