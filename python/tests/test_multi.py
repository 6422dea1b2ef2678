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
