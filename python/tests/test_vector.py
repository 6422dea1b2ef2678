"""flockway.VectorEnv: N environments stepped together on threads give exactly what each gives
alone; a Sim steps on any thread."""

from __future__ import annotations

import threading

import gymnasium as gym
import numpy as np
import pytest

import flockway
from flockway.vector import VectorEnv

KW = {"warmup_s": 5.0, "episode_s": 3.0}


def _alone(n: int, seed: int, actions: np.ndarray) -> tuple[list, list]:
    """Each environment on its own, one after another, with next-step autoreset by hand."""
    obs_all, rewards_all = [], []
    for i in range(n):
        env = gym.make("flockway/RingWave-v0", **KW)
        obs, _ = env.reset(seed=seed + i)
        seq_obs, seq_r, done = [obs], [], False
        for a in actions[:, i]:
            if done:
                obs, _ = env.reset()
                r, done = 0.0, False
            else:
                obs, r, term, trunc, _ = env.step(a)
                done = term or trunc
            seq_obs.append(obs)
            seq_r.append(r)
        obs_all.append(seq_obs)
        rewards_all.append(seq_r)
    return obs_all, rewards_all


def test_four_envs_stepped_together_equal_four_stepped_alone_bit_for_bit() -> None:
    n, steps = 4, 35  # 30 steps of 0.1 s per episode: an autoreset on the way
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, size=(steps, n, 1)).astype(np.float32)
    venv = VectorEnv("flockway/RingWave-v0", num_envs=n, threads=4, **KW)
    assert venv.observation_space.shape == (n, 4) and venv.action_space.shape == (n, 1)
    obs, infos = venv.reset(seed=100)
    got_obs, got_r = [obs], []
    dones = 0
    for a in actions:
        obs, r, term, trunc, _ = venv.step(a)
        got_obs.append(obs)
        got_r.append(r)
        dones += int((term | trunc).sum())
    venv.close()
    assert dones == n, "each episode ended once"
    want_obs, want_r = _alone(n, 100, actions)
    for i in range(n):
        assert np.array_equal(np.stack([o[i] for o in got_obs]), np.stack(want_obs[i]))
        assert np.array_equal(np.array([r[i] for r in got_r]), np.array(want_r[i]))


def test_env_fns_and_bad_arguments() -> None:
    fns = [lambda: gym.make("flockway/RingWave-v0", **KW)] * 2
    venv = VectorEnv(env_fns=fns, threads=1)
    obs, _ = venv.reset(seed=[1, 2])
    assert obs.shape == (2, 4)
    venv.close()
    with pytest.raises(ValueError, match="not both"):
        VectorEnv("flockway/RingWave-v0", 2, env_fns=fns)
    with pytest.raises(ValueError, match="num_envs"):
        VectorEnv("flockway/RingWave-v0", 0)
    assert flockway.VectorEnv is VectorEnv


def test_a_sim_made_on_one_thread_steps_on_another() -> None:
    sim = flockway.Sim("sugiyama_ring", seed=1, csv=False)
    errors: list[BaseException] = []

    def run() -> None:
        try:
            sim.step(240)
        except BaseException as e:  # noqa: BLE001  (reported below)
            errors.append(e)

    t = threading.Thread(target=run)
    t.start()
    t.join()
    assert not errors, errors
    assert sim.time_s == 2.0


def test_a_second_thread_calling_into_a_stepping_sim_gets_runtime_error() -> None:
    sim = flockway.Sim("sugiyama_ring", seed=1, csv=False)
    started = threading.Event()

    def run() -> None:
        started.set()
        sim.step(30_000)  # about a second and a half of stepping

    t = threading.Thread(target=run)
    t.start()
    started.wait()
    import time

    time.sleep(0.05)
    with pytest.raises(RuntimeError):
        sim.vehicles()
    t.join()
    assert sim.time_s == 250.0
