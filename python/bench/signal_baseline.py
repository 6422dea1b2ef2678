"""Signal-control baselines on the 2×2 grid (``signal_grid``): the level's fixed-time program,
the max-pressure rule, and optionally a short PPO run, compared on the network's mean waiting
time (the mean over decisions of the vehicles' mean waiting on every junction's incoming lanes).

    python python/bench/signal_baseline.py --seeds 1 2 3            # fixed-time vs max-pressure
    python python/bench/signal_baseline.py --seeds 1 2 3 --ppo 20000 # and PPO (stable-baselines3)
    python python/bench/signal_baseline.py --seeds 1 2 3 --policies random  # a stress test

``random`` picks every junction's phase at random at each decision (a generator seeded by the
episode's seed): a controller no driver should crash under.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from flockway.multi import signal_parallel_env
from flockway.signals import max_pressure


def episode(policy: str, seed: int, level: str, episode_s: float, model=None) -> dict[str, float]:
    """One episode of every junction under ``policy``: its mean waiting, s, and mean halting."""
    env = signal_parallel_env(level=level, fixed_time=policy == "fixed-time",
                              episode_s=episode_s)
    obs, infos = env.reset(seed=seed)
    waiting, halting = [], []
    rng = np.random.default_rng(seed)
    while env.agents:
        if policy == "random":
            actions = {a: int(rng.integers(env.action_space(a).n)) for a in env.agents}
        elif policy == "max-pressure":
            actions = {a: max_pressure(env.controlled[a], env.sim) for a in env.agents}
        elif policy == "ppo":
            actions = {a: int(model.predict(obs[a], deterministic=True)[0]) for a in env.agents}
        else:
            actions = {a: 0 for a in env.agents}
        obs, _, _, _, infos = env.step(actions)
        first = next(iter(infos.values()))
        waiting.append(first["system_waiting_s"])
        halting.append(first["system_halting"])
    summary = env.sim.summary()
    return {
        "waiting_s": float(np.mean(waiting)),
        "halting": float(np.mean(halting)),
        "arrived": float(summary["metrics"]["vehicles_destroyed"]),
        "collisions": float(env.sim.collisions),
    }


def train_ppo(steps: int, level: str, episode_s: float):
    """A short PPO run on one junction-agent's environment (the grid's first junction; the
    policy then drives every junction)."""
    import gymnasium as gym
    from stable_baselines3 import PPO

    env = gym.make("flockway/SignalControl-v0", level=level, episode_s=episode_s)
    model = PPO("MlpPolicy", env, n_steps=240, batch_size=60, learning_rate=1e-3, seed=0,
                verbose=0)
    model.learn(total_timesteps=steps)
    return model


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--level", default="signal_grid")
    ap.add_argument("--episode-s", type=float, default=600.0)
    ap.add_argument("--ppo", type=int, default=0, help="PPO training steps (0: no PPO)")
    ap.add_argument("--policies", nargs="+", default=["fixed-time", "max-pressure"],
                    choices=["fixed-time", "max-pressure", "random"])
    args = ap.parse_args()
    policies = list(args.policies)
    model = None
    if args.ppo:
        t = time.perf_counter()
        model = train_ppo(args.ppo, args.level, args.episode_s)
        print(f"PPO: {args.ppo} steps trained in {time.perf_counter() - t:.0f} s")
        policies.append("ppo")
    print("| policy | seed | mean waiting, s | mean halting | vehicles out | contacts |")
    print("|---|---|---|---|---|---|")
    for policy in policies:
        for seed in args.seeds:
            r = episode(policy, seed, args.level, args.episode_s, model)
            print(f"| {policy} | {seed} | {r['waiting_s']:.2f} | {r['halting']:.1f} | "
                  f"{r['arrived']:.0f} | {r['collisions']:.0f} |", flush=True)


if __name__ == "__main__":
    main()
