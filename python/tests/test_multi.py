"""The PettingZoo ParallelEnv."""

from __future__ import annotations

import numpy as np
from pettingzoo.test import parallel_api_test

from flockway.multi import parallel_env


def test_the_parallel_env_passes_pettingzoo_s_api_test() -> None:
    env = parallel_env(level="sugiyama_ring", profile="human", warmup_s=2.0, episode_s=3.0)
    parallel_api_test(env, num_cycles=40)


def test_every_vehicle_of_the_profile_is_an_agent_and_seeds_repeat() -> None:
    def play(seed: int):
        env = parallel_env(level="sugiyama_ring", profile="human", warmup_s=2.0, episode_s=2.0)
        obs, _ = env.reset(seed=seed)
        assert len(env.agents) == 22 and set(obs) == set(env.agents)
        rng = np.random.default_rng(3)
        total = 0.0
        while env.agents:
            actions = {a: rng.uniform(-1, 1, size=1).astype(np.float32) for a in env.agents}
            obs, rewards, terms, truncs, _ = env.step(actions)
            total += sum(rewards.values())
        return total, obs

    (a, oa), (b, ob) = play(9), play(9)
    assert a == b
    assert all(np.array_equal(oa[k], ob[k]) for k in oa)


def test_vehicles_spawned_during_the_episode_join_as_agents_and_leave_when_gone() -> None:
    # signal_queue starts empty: a car every 4.5-6.5 s from its one spawner.
    env = parallel_env(level="signal_queue", profile="autonomous", warmup_s=10.0,
                       episode_s=60.0)
    assert len(env.possible_agents) >= 16
    parallel_api_test(env, num_cycles=100)
    obs, _ = env.reset(seed=5)
    assert env.agents and set(obs) == set(env.agents)
    seen = set(env.agents)
    joined = []
    while env.agents:
        before = set(env.agents)
        obs, rewards, terms, truncs, infos = env.step({a: np.zeros(1, np.float32)
                                                       for a in env.agents})
        new = set(env.agents) - before
        assert set(rewards) == before | new, "an entry for every agent, newcomers' 0"
        assert all(rewards[a] == 0.0 for a in new)
        for a in new:
            assert a in obs and a in env.possible_agents and a not in seen
            assert env.observation_space(a).contains(obs[a])
        joined += sorted(new, key=lambda a: int(a.split("_")[1]))
        seen |= new
    # 60 s at a car every 4.5-6.5 s: 9 to 14 more.
    assert 9 <= len(joined) <= 14, joined
    ids = [int(a.split("_")[1]) for a in joined]
    assert ids == sorted(ids)


def test_a_level_with_neither_the_profile_nor_spawners_is_refused() -> None:
    import pytest

    with pytest.raises(ValueError, match="no vehicle of driver profile `nobody`"):
        parallel_env(level="sugiyama_ring", profile="nobody")
