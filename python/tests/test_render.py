"""Pictures: the off-screen renderer (Mesa's lavapipe in CI) through Sim.render and the
environments' render_mode="rgb_array"."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import flockway
from flockway.multi import parallel_env

#: The ground and asphalt colours of the scene (sRGB), and a car's (the autonomous profile's
#: blue, human-like drivers' red): each frame must show them.
GROUND = np.array([125, 152, 110])
ASPHALT = np.array([72, 72, 76])


def share_near(frame: np.ndarray, colour: np.ndarray, tolerance: int = 12) -> float:
    """The share of the frame's pixels within ``tolerance`` of ``colour`` on every channel."""
    return float((np.abs(frame.astype(int) - colour) <= tolerance).all(axis=2).mean())


def test_sim_render_draws_the_scene_as_rgb_bytes_and_is_repeatable() -> None:
    s = flockway.Sim("stern_ring", seed=1)
    s.step(120 * 10)
    frame = s.render(320, 240)
    assert frame.shape == (240, 320, 3) and frame.dtype == np.uint8
    assert share_near(frame, GROUND) > 0.4
    assert share_near(frame, ASPHALT) > 0.03
    # Cars: saturated red (human-like) and blue (the autonomous one) pixels.
    red = (frame[..., 0] > 150) & (frame[..., 1] < 90)
    blue = (frame[..., 2] > 150) & (frame[..., 0] < 90)
    assert red.sum() > 100 and blue.sum() > 5
    assert (s.render(320, 240) == frame).all()
    # A box 40 m across around the first car: a few cars, each drawn five times larger.
    box = s.region_around(int(s.vehicles()["id"][0]), 40.0, 320 / 240)
    close = s.render(320, 240, region=box)
    close_red = (close[..., 0] > 150) & (close[..., 1] < 90)
    assert close_red.sum() > 0.5 * red.sum()
    assert not (close == frame).all()
    assert s.render(200, 200, view="orbit").shape == (200, 200, 3)


def test_sim_render_refuses_bad_sizes_views_and_regions() -> None:
    s = flockway.Sim("stern_ring", seed=1)
    with pytest.raises(ValueError, match="16 to 8192"):
        s.render(4, 4)
    with pytest.raises(ValueError, match="view `side`"):
        s.render(64, 64, view="side")
    with pytest.raises(ValueError, match="x0 < x1"):
        s.render(64, 64, region=(10.0, 0.0, -10.0, 5.0))
    with pytest.raises(KeyError):
        s.region_around(123456)


def test_environments_render_rgb_array_frames() -> None:
    env = gym.make("flockway/RingWave-v0", render_mode="rgb_array")
    check_env(env.unwrapped)
    env.reset(seed=2)
    env.step(np.array([0.0], dtype=np.float32))
    frame = env.render()
    assert frame.shape == (480, 640, 3) and frame.dtype == np.uint8
    assert share_near(frame, ASPHALT) > 0.03
    with pytest.raises(ValueError, match="render_mode 'ansi'"):
        flockway.envs.RingWaveEnv(render_mode="ansi")
    plain = gym.make("flockway/RingWave-v0")
    plain.reset(seed=2)
    assert plain.render() is None

    merge = gym.make("flockway/Merge-v0", render_mode="rgb_array")
    merge.reset(seed=1)
    frame = merge.render()
    # 120 m around the merging car: the one-lane ramp, and the car itself.
    assert share_near(frame, ASPHALT) > 0.01
    assert ((frame[..., 2] > 150) & (frame[..., 0] < 90)).sum() > 50

    many = parallel_env(level="sugiyama_ring", profile="human", render_mode="rgb_array")
    many.reset(seed=1)
    assert many.render().shape == (480, 640, 3)


def test_render_options_pass_through_gym_make_and_bad_ones_raise() -> None:
    env = gym.make("flockway/RingWave-v0", render_mode="rgb_array", render_size=(320, 200))
    env.reset(seed=2)
    assert env.render().shape == (200, 320, 3)
    # The Merge car's surroundings 60 m across, or the whole level.
    near = gym.make("flockway/Merge-v0", render_mode="rgb_array", render_width_m=60.0)
    near.reset(seed=1)
    whole = gym.make("flockway/Merge-v0", render_mode="rgb_array", render_width_m=None)
    whole.reset(seed=1)
    assert near.unwrapped.render_width_m == 60.0 and whole.unwrapped.render_width_m is None
    assert share_near(near.render(), ASPHALT) > share_near(whole.render(), ASPHALT)
    with pytest.raises(ValueError, match="render_size"):
        gym.make("flockway/RingWave-v0", render_size=(4, 4))
    with pytest.raises(ValueError, match="render_width_m"):
        gym.make("flockway/Merge-v0", render_width_m=-5.0)
    many = parallel_env(level="sugiyama_ring", profile="human", render_mode="rgb_array",
                        render_size=(200, 160))
    many.reset(seed=1)
    assert many.render().shape == (160, 200, 3)
