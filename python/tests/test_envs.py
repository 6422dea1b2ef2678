"""The gymnasium environments."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import flockway  # noqa: F401  (registers the environments)


def test_ring_wave_passes_check_env() -> None:
    env = gym.make("flockway/RingWave-v0", warmup_s=2.0, episode_s=5.0)
    check_env(env.unwrapped)


def test_two_resets_with_one_seed_give_the_same_episode() -> None:
    def episode() -> list[np.ndarray]:
        env = gym.make("flockway/RingWave-v0", warmup_s=5.0, episode_s=60.0)
        obs, _ = env.reset(seed=42)
        env.action_space.seed(7)
        seen = [obs]
        for _ in range(100):
            obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
            seen.append(np.append(obs, reward))
            assert not terminated
        return seen

    a, b = episode(), episode()
    assert all(np.array_equal(x, y) for x, y in zip(a, b))


def test_level_env_takes_any_profile_of_any_level() -> None:
    env = gym.make("flockway/Level-v0", level="sugiyama_ring", profile="human",
                   warmup_s=1.0, episode_s=1.0)
    obs, info = env.reset(seed=1)
    assert info["vehicle"] == 0
    assert env.observation_space.contains(obs)
    done = False
    steps = 0
    while not done:
        obs, reward, terminated, truncated, _ = env.step(np.array([0.0], dtype=np.float32))
        done = terminated or truncated
        steps += 1
    assert steps == 10


def test_merge_puts_the_agent_in_a_car_on_the_ramp_until_it_leaves() -> None:
    env = gym.make("flockway/Merge-v0", warmup_s=20.0, episode_s=80.0)
    check_env(env.unwrapped)
    obs, info = env.reset(seed=3)
    sim = env.unwrapped.sim
    v = sim.vehicles()
    assert v["road"][v["id"] == info["vehicle"]][0] == "ramp"
    roads = set()
    for _ in range(800):
        obs, reward, terminated, truncated, _ = env.step(np.array([1.0], dtype=np.float32))
        v = sim.vehicles()
        roads.update(v["road"][v["id"] == info["vehicle"]].tolist())
        if terminated or truncated:
            break
    # Flat out, it merged and drove the rest of the motorway to the exit within 80 s.
    assert terminated and {"ramp", "merge", "downstream"} <= roads


def test_environments_write_no_telemetry_unless_given_a_path(tmp_path) -> None:
    env = gym.make("flockway/RingWave-v0", warmup_s=2.0, episode_s=2.0)
    env.reset(seed=1)
    assert env.unwrapped.sim.csv is None
    with pytest.raises(RuntimeError, match="csv=False"):
        env.unwrapped.sim.telemetry()
    path = tmp_path / "episode.csv"
    kept = gym.make("flockway/RingWave-v0", warmup_s=2.0, episode_s=2.0, telemetry=path)
    kept.reset(seed=1)
    for _ in range(5):
        kept.step(np.array([0.0], dtype=np.float32))
    frame = kept.unwrapped.sim.telemetry()
    assert len(frame) > 0 and path.is_file()
    # The same episode with and without telemetry.
    obs_a, _ = env.reset(seed=3)
    obs_b, _ = kept.reset(seed=3)
    assert (obs_a == obs_b).all()
    for _ in range(5):
        a = env.step(np.array([0.5], dtype=np.float32))
        b = kept.step(np.array([0.5], dtype=np.float32))
        assert (a[0] == b[0]).all() and a[1] == b[1]
    from flockway.multi import parallel_env

    many = parallel_env(level="sugiyama_ring", profile="human", warmup_s=1.0, episode_s=1.0)
    many.reset(seed=1)
    assert many.sim.csv is None


def test_reset_draws_the_levels_seed_from_the_reset_seed_and_says_it() -> None:
    env = gym.make("flockway/RingWave-v0", warmup_s=1.0, episode_s=1.0)
    _, first = env.reset(seed=5)
    _, second = env.reset()
    _, again = env.reset(seed=5)
    assert first["seed"] == again["seed"] != second["seed"]
    assert first["seed"] != 5
    # The level's seed replays the episode's warm-up, bit for bit.
    sim = flockway.Sim("stern_ring", seed=again["seed"], csv=False)
    played = env.unwrapped.sim
    sim.step(round(played.time_s * 120))
    assert sim.time_s == played.time_s
    assert (sim.vehicles()["x_m"] == played.vehicles()["x_m"]).all()


def test_on_a_level_that_starts_empty_the_agent_is_the_first_car_spawned_after_the_warmup() -> None:
    import gymnasium as gym

    env = gym.make("flockway/Level-v0", level="signal_queue", profile="autonomous",
                   warmup_s=20.0, episode_s=5.0)
    check_env(env.unwrapped, skip_render_check=True)
    obs, info = env.reset(seed=3)
    u = env.unwrapped
    v = u.sim.vehicles()
    # The newest car: spawned after the warm-up, at the spawner, the only one that young.
    assert info["vehicle"] == int(v["id"].max())
    at = v["id"] == info["vehicle"]
    assert v["road"][at][0] == "approach" and v["s_m"][at][0] < 30.0
    assert info["time_s"] > 20.0
    env = gym.make("flockway/Level-v0", level="crossroads_signal", profile="autonomous",
                   agent_spawner="north", warmup_s=10.0, episode_s=5.0)
    obs, info = env.reset(seed=1)
    v = env.unwrapped.sim.vehicles()
    assert v["road"][v["id"] == info["vehicle"]][0] == "north in"
    import pytest

    with pytest.raises(ValueError, match="no spawner `up`; its spawners are: west, east, south, north"):
        gym.make("flockway/Level-v0", level="crossroads_signal", agent_spawner="up")


@pytest.mark.parametrize("action", ["acceleration", "continuous", "discrete"])
@pytest.mark.parametrize("observation", ["default", "kinematics", "lanes"])
def test_each_observation_and_action_type_passes_check_env(observation: str, action: str) -> None:
    env = gym.make("flockway/Level-v0", level="on_ramp", profile="autonomous", warmup_s=10.0,
                   episode_s=3.0, observation=observation, action=action, vehicles_count=4)
    check_env(env.unwrapped, skip_render_check=True)
    obs, _ = env.reset(seed=2)
    assert env.observation_space.contains(obs)
    if observation == "kinematics":
        assert obs.shape == (4, 5) and obs[0, 0] == 1.0 and obs[0, 1] == 0.0
        assert obs[1:, 0].sum() == 3.0, "three neighbours on the motorway"
        dist = np.hypot(obs[1:, 1], obs[1:, 2])
        assert np.all(np.diff(dist) >= 0), "nearest first"
    if observation == "lanes":
        assert obs.shape == (2, 5, 30)
        assert obs[0, 2, 10] == 1.0 and obs[1, 2, 10] == 0.0, "the agent, mid-row, 50 m in"


def test_the_lanes_grid_puts_each_vehicle_in_its_lane_and_cell() -> None:
    env = gym.make("flockway/Level-v0", level="dense_road", profile="autonomous", warmup_s=20.0,
                   episode_s=5.0, observation="lanes", lanes_count=7)
    obs, info = env.reset(seed=4)
    sim, me = env.unwrapped.sim, info["vehicle"]
    v = sim.vehicles()
    k = int(np.flatnonzero(v["id"] == me)[0])
    # On the straight first 200 m the road runs along x: lanes and cells from x, y alone.
    assert v["x_m"][k] < 150.0 and abs(v["heading_rad"][k]) < 0.05
    expected = np.zeros((7, 30))
    for i in range(len(v["id"])):
        dx, dy = v["x_m"][i] - v["x_m"][k], v["y_m"][i] - v["y_m"][k]
        row, col = 3 - int(np.floor(dy / 3.5 + 0.5)), int(np.floor((dx + 50.0) / 5.0))
        if 0 <= row < 7 and 0 <= col < 30 and v["x_m"][i] < 200.0:
            expected[row, col] = 1.0
    assert expected.sum() >= 10, "a dense road"
    np.testing.assert_array_equal(obs[0], expected)
    assert np.all(obs[1][obs[0] == 0.0] == 0.0), "speeds only where there is a vehicle"


def test_reward_terms_are_reported_and_weighted() -> None:
    common = dict(level="stern_ring", warmup_s=5.0, episode_s=4.0)
    plain = gym.make("flockway/Level-v0", **common)
    weighted = gym.make("flockway/Level-v0", **common, accel_penalty=0.3,
                        reward_weights={"agent_speed": 0.5, "mean_speed": 0.0,
                                        "close_headway": -2.0})
    plain.reset(seed=5)
    weighted.reset(seed=5)
    for action in ([1.0], [-1.0], [0.2], [0.0]):
        _, r0, _, _, i0 = plain.step(action)
        _, r1, _, _, i1 = weighted.step(action)
        terms = i1["reward_terms"]
        assert terms == i0["reward_terms"], "the same run: the weights only weigh"
        assert set(terms) == set(flockway.envs.REWARD_TERMS)
        # The default: mean speed less 0.1 a² and 100 per contact.
        assert r0 == pytest.approx(terms["mean_speed"] - 0.1 * terms["accel_sq"]
                                   - 100.0 * terms["collisions"])
        # Given weights replace those terms; accel_penalty still sets accel_sq's.
        assert r1 == pytest.approx(0.5 * terms["agent_speed"] - 0.3 * terms["accel_sq"]
                                   - 100.0 * terms["collisions"] - 2.0 * terms["close_headway"])
        assert terms["agent_speed"] > 0.0 and terms["lane_change"] == 0.0
    with pytest.raises(ValueError, match="unknown term 'comfort'; the terms are mean_speed"):
        gym.make("flockway/Level-v0", reward_weights={"comfort": 1.0})
    with pytest.raises(ValueError, match="lanes_count=0"):
        gym.make("flockway/Level-v0", observation="lanes", lanes_count=0)


def test_discrete_meta_actions_change_lane_and_speed() -> None:
    env = gym.make("flockway/Level-v0", level="dense_road", profile="autonomous",
                   warmup_s=5.0, episode_s=60.0, action="discrete")
    env.reset(seed=1)
    u = env.unwrapped
    v = u.sim.vehicles()
    road = str(v["road"][v["id"] == u.agent][0])
    lanes = next(r["lanes"] for r in flockway.Level("dense_road").to_dict()["roads"]
                 if r["name"] == road)
    start_speed, lane0 = u._speed()
    assert lanes >= 2
    # Away from the edge it is at, then back.
    first, back = (2, 0) if lane0 == lanes - 1 else (0, 2)
    for _ in range(60):
        env.step(first)
    lane1 = u._speed()[1]
    assert lane1 != lane0 and abs(lane1 - lane0) >= 1
    for _ in range(60):
        env.step(back)
    assert (u._speed()[1] - lane1) * (lane0 - lane1) > 0, "back towards where it was"
    target = u._target_mps
    for _ in range(5):
        env.step(3)  # faster
    assert u._target_mps == pytest.approx(min(target + 12.5, 40.0))
    for _ in range(100):
        env.step(4)  # slower
    assert u._target_mps == 0.0
    assert u._speed()[0] < 0.5, "it stops when its target is 0"


def test_a_custom_observation_and_bad_types() -> None:
    from gymnasium import spaces

    def mine(sim, vehicle):
        return np.array([sim.time_s], dtype=np.float32)

    box = spaces.Box(0.0, 1e6, shape=(1,), dtype=np.float32)
    env = gym.make("flockway/Level-v0", level="stern_ring", warmup_s=1.0, episode_s=1.0,
                   observation=mine, observation_space=box)
    obs, _ = env.reset(seed=0)
    assert obs[0] == 1.0, "the warm-up's end"
    with pytest.raises(ValueError, match="observation 'pixels'"):
        gym.make("flockway/Level-v0", observation="pixels")
    with pytest.raises(ValueError, match="needs its observation_space"):
        gym.make("flockway/Level-v0", observation=mine)
    with pytest.raises(ValueError, match="action 'steer'"):
        gym.make("flockway/Level-v0", action="steer")
