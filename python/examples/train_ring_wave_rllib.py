"""Trains a policy for the Stern ring task (``flockway/RingWave-v0``) with RLlib's PPO, then
plays it on the ring and compares what it does to the human drivers with the built-in
wave-damping car and with a car that only holds its speed.

    pip install . "ray[rllib]==2.60.0" torch
    python python/examples/train_ring_wave_rllib.py [--iterations 40] [--seeds 11,12,13]

The agent observes its speed, the gap to its leader, the leader's speed and the ring's mean
speed, and asks for an acceleration every 0.1 s; a step earns the ring's mean speed less a
penalty for harsh acceleration and for contacts (see docs/python.md). Training runs on one
environment runner per CPU; the evaluation replays each seed with the policy's most likely
action on the registered 240 s task and reads the humans' speed spread and mean from the run's
summary (measured from 150 s, as the challenge ``damp_the_wave`` does).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import flockway
from flockway.envs import RingWaveEnv


def make_env(config: dict) -> RingWaveEnv:
    return RingWaveEnv(**config)


def play(policy, seed: int, env_config: dict) -> dict[str, float]:
    """One episode with ``policy(obs) -> action``; the humans' figures from the summary."""
    env = RingWaveEnv(**env_config)
    obs, _ = env.reset(seed=seed)
    total, done = 0.0, False
    while not done:
        obs, reward, terminated, truncated, _ = env.step(policy(obs))
        total += reward
        done = terminated or truncated
    m = env.sim.summary()["metrics"]
    return {
        "return": total,
        "spread_kmh": m["speed_std_kmh.human"],
        "mean_kmh": m["mean_speed_kmh.human"],
        "collisions": m["collisions"],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--iterations", type=int, default=40)
    parser.add_argument("--seeds", default="11,12,13", help="evaluation seeds")
    parser.add_argument("--runners", type=int, default=2, help="environment runners")
    args = parser.parse_args()

    import ray
    import torch
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.columns import Columns
    from ray.tune.registry import register_env

    torch.manual_seed(0)
    # Episodes of 120 s under the agent after the 60 s warm-up (the summary's figures then
    # cover 150-180 s): quicker iterations than the registered 240 s.
    env_config = {"episode_s": 120.0}
    ray.init(num_cpus=max(2, args.runners), include_dashboard=False)
    register_env("ring_wave", make_env)
    config = (
        PPOConfig()
        .environment("ring_wave", env_config=env_config)
        .env_runners(num_env_runners=args.runners, rollout_fragment_length=1000)
        .training(
            train_batch_size_per_learner=4000,
            minibatch_size=250,
            num_epochs=10,
            lr=3e-4,
            gamma=0.99,
            lambda_=0.95,
        )
        .debugging(seed=0)
    )
    algo = config.build_algo()
    started = time.time()
    for i in range(args.iterations):
        result = algo.train()
        runners = result.get("env_runners", {})
        print(
            f"iteration {i + 1}: return {runners.get('episode_return_mean', float('nan')):.0f}, "
            f"{runners.get('num_env_steps_sampled_lifetime', 0)} steps, "
            f"{time.time() - started:.0f} s",
            flush=True,
        )

    module = algo.get_module()

    def trained(obs: np.ndarray) -> np.ndarray:
        batch = {Columns.OBS: torch.from_numpy(obs[None, :].astype(np.float32))}
        out = module.forward_inference(batch)
        # The Gaussian's mean: the first half of the distribution inputs.
        mean = out[Columns.ACTION_DIST_INPUTS][0, :1].detach().numpy()
        return np.clip(mean, -1.0, 1.0).astype(np.float32)

    def hold(obs: np.ndarray) -> np.ndarray:
        return np.zeros(1, dtype=np.float32)

    seeds = [int(s) for s in args.seeds.split(",")]
    # Evaluated on the registered task (240 s under the agent): the humans' figures over
    # 150-300 s, as stern_ring's and damp_the_wave's.
    print("evaluation (the humans' speed spread and mean, km/h, over 150-300 s):")
    for name, policy in (("trained PPO", trained), ("holds its speed", hold)):
        rows = [play(policy, s, {}) for s in seeds]
        print(
            f"  {name:<16} return {np.mean([r['return'] for r in rows]):8.0f}  "
            f"spread {np.mean([r['spread_kmh'] for r in rows]):5.2f}  "
            f"mean {np.mean([r['mean_kmh'] for r in rows]):5.2f}  "
            f"collisions {sum(r['collisions'] for r in rows):.0f}"
        )
    # The built-in wave-damping car through the same runs (the level's own car throughout).
    rows = []
    for s in seeds:
        _, info = RingWaveEnv().reset(seed=s)
        sim = flockway.Sim("stern_ring", seed=info["seed"])
        sim.run(300.0)
        m = sim.summary()["metrics"]
        rows.append((m["speed_std_kmh.human"], m["mean_speed_kmh.human"]))
    print(
        f"  {'WaveDamper':<16} return {'':>8}  spread {np.mean([r[0] for r in rows]):5.2f}  "
        f"mean {np.mean([r[1] for r in rows]):5.2f}"
    )
    ray.shutdown()


if __name__ == "__main__":
    main()
