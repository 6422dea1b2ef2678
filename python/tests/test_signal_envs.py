"""Signal control: flockway/SignalControl-v0 and its PettingZoo twin pass the APIs' checks, their
observations, actions and rewards are what the docs say, and max-pressure beats the fixed-time
program on the 2×2 grid."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import parallel_api_test

import flockway
from flockway.multi import signal_parallel_env
from flockway.signals import Junction, green_phases, max_pressure


def test_green_phases_are_the_states_with_green_and_no_amber_each_once() -> None:
    program = [(40.0, "GGgrrr"), (3.0, "yyyrrr"), (2.0, "rrrrrr"), (40.0, "rrrGGg"),
               (3.0, "rrryyy"), (5.0, "GGgrrr")]
    assert green_phases(program) == ["GGgrrr", "rrrGGg"]


def test_signal_control_passes_check_env_and_shapes_follow_the_junction() -> None:
    env = gym.make("flockway/SignalControl-v0", warmup_s=10.0, episode_s=30.0)
    check_env(env.unwrapped, skip_render_check=True)
    u = env.unwrapped
    j = u.junction
    # Two green phases; 4 approach lanes: one-hot 2, min-green flag, 4 densities, 4 queues.
    assert env.action_space.n == 2 == len(j.greens)
    assert env.observation_space.shape == (2 + 1 + 4 + 4,)
    obs, info = env.reset(seed=3)
    assert obs.dtype == np.float32 and env.observation_space.contains(obs)
    assert obs[0] == 1.0 and obs[1] == 0.0, "the first green phase, one-hot"
    assert obs[2] == 0.0, "the minimum green has not passed at the start"
    assert {"time_s", "waiting_s", "halting", "system_waiting_s", "system_halting", "seed"} <= set(info)
    assert u.sim.signals()[0]["mode"] == "held"


def test_an_action_switches_green_through_amber_and_all_red_after_the_minimum_green() -> None:
    env = gym.make("flockway/SignalControl-v0", warmup_s=10.0, episode_s=60.0, delta_time_s=1.0,
                   min_green_s=5.0, yellow_time_s=3.0, all_red_s=2.0)
    u = env.unwrapped
    env.reset(seed=1)
    greens = u.junction.greens
    name = u.junction_name

    def state() -> str:
        return next(s for s in u.sim.signals() if s["junction"] == name)["state"]

    # Before the minimum green, asking for the other phase changes nothing.
    obs, *_ = env.step(1)
    assert state() == greens[0] and obs[0] == 1.0
    for _ in range(4):
        obs, *_ = env.step(1)
    assert obs[2] == 1.0, "the minimum green has passed"
    # The switch: amber for the movements losing green, red for those gaining it ...
    obs, *_ = env.step(1)
    amber = state()
    assert all(a == "y" for g, a in zip(greens[0], amber) if g in "Gg")
    assert all(a == "r" for g, a in zip(greens[0], amber) if g not in "Gg")
    for _ in range(3):
        env.step(1)
    assert set(state()) == {"r"}, "then all red"
    for _ in range(2):
        env.step(1)
    assert state() == greens[1]
    assert obs[1] == 1.0 and obs[2] == 0.0


@pytest.mark.parametrize("reward", ["diff-waiting-time", "queue", "pressure"])
def test_each_named_reward_is_what_the_docs_say(reward: str) -> None:
    env = gym.make("flockway/SignalControl-v0", warmup_s=30.0, episode_s=60.0, reward=reward,
                   fixed_time=True)
    u = env.unwrapped
    env.reset(seed=2)
    name = u.junction_name
    lanes = u.sim.junctions()
    before = float(lanes["waiting_s"][lanes["junction"] == name].sum())
    _, r, *_ = env.step(0)
    lanes = u.sim.junctions()
    mine = lanes["junction"] == name
    if reward == "diff-waiting-time":
        assert r == pytest.approx((before - lanes["waiting_s"][mine].sum()) / 100.0)
    elif reward == "queue":
        assert r == -float(lanes["halting"][mine].sum())
    else:
        v = u.sim.vehicles()
        here = list(zip(v["road"].tolist(), v["lane"].tolist()))
        inflow = sum(here.count(lane) for lane in u.junction.in_lanes)
        outflow = sum(here.count(lane) for lane in u.junction.out_lanes)
        assert r == -float(inflow - outflow)


def test_a_callable_reward_and_bad_keywords() -> None:
    seen = []

    def mine(junction: Junction, sim: flockway.Sim) -> float:
        seen.append(junction.name)
        return 7.0

    env = gym.make("flockway/SignalControl-v0", warmup_s=5.0, episode_s=10.0, reward=mine)
    env.reset(seed=0)
    assert env.step(0)[1] == 7.0 and seen
    with pytest.raises(ValueError, match="reward 'fast'"):
        gym.make("flockway/SignalControl-v0", reward="fast")
    with pytest.raises(ValueError, match="no signalised junction `Z9`"):
        gym.make("flockway/SignalControl-v0", junction="Z9")
    with pytest.raises(ValueError, match="no signalised junction"):
        gym.make("flockway/SignalControl-v0", level="sugiyama_ring")
    with pytest.raises(ValueError, match="yellow_time_s"):
        gym.make("flockway/SignalControl-v0", yellow_time_s=-1.0)
    env = gym.make("flockway/SignalControl-v0", warmup_s=5.0, episode_s=10.0)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action 2"):
        env.step(2)


def test_the_same_seed_and_actions_give_the_same_episode() -> None:
    def play() -> list[float]:
        env = gym.make("flockway/SignalControl-v0", warmup_s=20.0, episode_s=60.0)
        obs, _ = env.reset(seed=11)
        out = [float(obs.sum())]
        for k in range(12):
            obs, r, *_ = env.step(k // 4 % 2)
            out += [float(obs.sum()), r]
        return out

    assert play() == play()


def test_the_parallel_twin_has_an_agent_per_junction_and_passes_the_api_test() -> None:
    env = signal_parallel_env(warmup_s=10.0, episode_s=40.0)
    assert env.possible_agents == ["A0", "A1", "B0", "B1"]
    parallel_api_test(env, num_cycles=10)
    obs, infos = env.reset(seed=4)
    assert set(obs) == set(env.agents) == {"A0", "A1", "B0", "B1"}
    for a in env.agents:
        assert env.observation_space(a).contains(obs[a])
    steps = 0
    while env.agents:
        _, rewards, terms, truncs, _ = env.step({a: 1 for a in env.agents})
        steps += 1
    assert steps == 8 and all(truncs.values()) and not any(terms.values())
    one = signal_parallel_env(junctions=["B1"], warmup_s=10.0, episode_s=10.0)
    assert one.possible_agents == ["B1"]


def _mean_waiting(policy: str, seed: int) -> tuple[float, int]:
    env = signal_parallel_env(fixed_time=policy == "fixed-time", episode_s=240.0)
    env.reset(seed=seed)
    waiting = []
    while env.agents:
        if policy == "max-pressure":
            actions = {a: max_pressure(env.controlled[a], env.sim) for a in env.agents}
        else:
            actions = {a: 0 for a in env.agents}
        _, _, _, _, infos = env.step(actions)
        waiting.append(next(iter(infos.values()))["system_waiting_s"])
    return float(np.mean(waiting)), env.sim.collisions


@pytest.mark.parametrize("seed", [21, 22, 23])
def test_max_pressure_beats_fixed_time_on_mean_waiting_on_the_grid(seed: int) -> None:
    fixed, fixed_contacts = _mean_waiting("fixed-time", seed)
    pressure, pressure_contacts = _mean_waiting("max-pressure", seed)
    assert pressure < fixed, (pressure, fixed)
    assert fixed_contacts == 0 and pressure_contacts == 0
