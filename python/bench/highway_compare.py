"""Environment steps per second of highway-env's ``highway-v0`` against Flockway's
``flockway/Level-v0`` set up the same way: the kinematics observation of the 5 nearest
vehicles, the 5 discrete meta-actions, one decision per simulated second, on a 4-lane road with
traffic. highway-env moves point-mass bicycles at 15 Hz; Flockway steps rigid bodies with tyres
and suspension at 120 Hz. Run it once in each environment that has the package:

    python python/bench/highway_compare.py --tool highway --steps 200   # pip install highway-env
    python python/bench/highway_compare.py --tool flockway --steps 200

Each prints one row: the tool, vehicles on the road (mean over the steps), environment steps
per second, simulated seconds per wall second and simulated vehicle-seconds per wall second.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

os.environ.setdefault("FLOCKWAY_THREADS", "1")


def _idle_rate(env, steps: int, vehicles) -> tuple[float, float]:
    """Environment steps per second over ``steps`` steps of the meta-action ``idle`` (1) after
    a reset with seed 0, and the mean of ``vehicles(env)`` over them."""
    env.reset(seed=0)
    counts = []
    t = time.perf_counter()
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(1)
        counts.append(vehicles(env))
        if terminated or truncated:
            env.reset()
    return steps / (time.perf_counter() - t), float(np.mean(counts))


def highway(steps: int) -> tuple[float, float, float]:
    import gymnasium as gym
    import highway_env  # noqa: F401  (registers the environments)

    env = gym.make("highway-v0")  # 4 lanes, 50 vehicles, 1 decision/s, 15 Hz simulation
    env.unwrapped.config["duration"] = 10**6
    rate, vehicles = _idle_rate(env, steps, lambda e: len(e.unwrapped.road.vehicles))
    return rate, 1.0 / env.unwrapped.config["policy_frequency"], vehicles


def flockway(steps: int) -> tuple[float, float, float]:
    import gymnasium as gym

    import flockway  # noqa: F401  (registers the environments)

    env = gym.make("flockway/Level-v0", level="dense_road", profile="autonomous",
                   warmup_s=30.0, episode_s=10**6, observation="kinematics",
                   action="discrete", period_s=1.0)
    rate, vehicles = _idle_rate(env, steps, lambda e: len(e.unwrapped.sim.vehicles()["id"]))
    return rate, 1.0, vehicles


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tool", choices=["highway", "flockway"], required=True)
    ap.add_argument("--steps", type=int, default=200)
    args = ap.parse_args()
    rate, period_s, vehicles = (highway if args.tool == "highway" else flockway)(args.steps)
    print("| tool | vehicles | env steps/s | simulated s per wall s | vehicle-s per wall s |")
    print(f"| {args.tool} | {vehicles:.0f} | {rate:.1f} | {rate * period_s:.1f} | "
          f"{rate * period_s * vehicles:.0f} |")


if __name__ == "__main__":
    main()
