"""Environment steps per second for 1, 2, 4 and 8 environments of ``flockway/RingWave-v0``:
stepped one after another in one process, as ``flockway.VectorEnv`` (threads, one process) and
as gymnasium's ``AsyncVectorEnv`` (a subprocess each). Every simulation runs with a one-thread
task pool (``FLOCKWAY_THREADS=1``), so the environments share the cores.

    FLOCKWAY_THREADS=1 python python/bench/vector_throughput.py --steps 300
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("FLOCKWAY_THREADS", "1")

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402

import flockway  # noqa: E402, F401  (registers the environments)
from flockway.vector import VectorEnv  # noqa: E402

ENV = "flockway/RingWave-v0"
KW = {"warmup_s": 1.0, "episode_s": 1e6}


def make() -> gym.Env:
    return gym.make(ENV, **KW)


def rate(venv, steps: int) -> float:
    """Environment steps per second over ``steps`` vector steps (after the reset)."""
    venv.reset(seed=0)
    actions = np.zeros(venv.action_space.shape, dtype=np.float32)
    t = time.perf_counter()
    for _ in range(steps):
        venv.step(actions)
    return steps * venv.num_envs / (time.perf_counter() - t)


def sequential(n: int, steps: int) -> float:
    envs = [make() for _ in range(n)]
    for i, e in enumerate(envs):
        e.reset(seed=i)
    a = np.zeros(1, dtype=np.float32)
    t = time.perf_counter()
    for _ in range(steps):
        for e in envs:
            e.step(a)
    return steps * n / (time.perf_counter() - t)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--envs", type=int, nargs="+", default=[1, 2, 4, 8])
    args = ap.parse_args()
    print(f"{os.cpu_count()} cores; {ENV}, 0.1 s of simulated time (12 steps of 1/120 s) per "
          "environment step")
    print("| envs | one after another | flockway.VectorEnv (threads) | AsyncVectorEnv "
          "(subprocesses) |")
    print("|---|---|---|---|")
    for n in args.envs:
        seq = sequential(n, args.steps)
        venv = VectorEnv(env_fns=[make] * n)
        threaded = rate(venv, args.steps)
        venv.close()
        avenv = gym.vector.AsyncVectorEnv([make] * n)
        proc = rate(avenv, args.steps)
        avenv.close()
        print(f"| {n} | {seq:.0f} | {threaded:.0f} | {proc:.0f} |", flush=True)


if __name__ == "__main__":
    main()
