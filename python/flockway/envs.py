"""Gymnasium environments: one vehicle of a level driven by the agent's acceleration, among the
level's own drivers.

``flockway/RingWave-v0`` is the Stern et al. (2018) ring task: the one autonomous car among 21
human-like drivers on the Sugiyama ring, rewarded for the ring's mean speed with a penalty for
harsh acceleration and for collisions. ``flockway/Merge-v0`` puts the agent in
the merging car of ``on_ramp``. ``flockway/Level-v0`` is the same task on any level, with any
driver profile's first vehicle (or the first on a given road) as the agent.
"""

from __future__ import annotations

import os
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from .sim import DT_S, Sim

#: The observation's entries, in order.
OBSERVATION = ("speed_mps", "gap_m", "leader_speed_mps", "mean_speed_mps")

#: Marks a keyword left out (``None`` means something for ``render_width_m``).
DEFAULT: Any = object()


def render_size_of(size: Any) -> tuple[int, int]:
    """A frame size ``(width, height)`` in pixels, 16 to 8192 each, or ``ValueError``."""
    try:
        w, h = (int(v) for v in size)
    except (TypeError, ValueError):
        raise ValueError(f"render_size={size!r}: expected (width, height) in pixels") from None
    if not (16 <= w <= 8192 and 16 <= h <= 8192):
        raise ValueError(f"render_size={size!r}: each side 16 to 8192 pixels")
    return (w, h)


def render_width_of(width: Any) -> float | None:
    """Ground across a frame, m (more than 0), or ``None`` for the whole level."""
    if width is None:
        return None
    w = float(width)
    if not (w > 0.0 and w < float("inf")):
        raise ValueError(f"render_width_m={width!r}: expected metres above 0, or None")
    return w


#: The gap reported when there is no leader within range, m (also the observation's bound).
MAX_GAP_M = 500.0


def observation_space() -> spaces.Box:
    """What an agent observes (see :data:`OBSERVATION`), m and m/s."""
    high = np.array([60.0, MAX_GAP_M, 60.0, 60.0], dtype=np.float32)
    low = np.array([-20.0, 0.0, -20.0, -20.0], dtype=np.float32)
    return spaces.Box(low, high, dtype=np.float32)


#: The default observation's space, under a name the environments' keyword does not hide.
_default_observation_space = observation_space


def action_space() -> spaces.Box:
    """An agent's action: a target acceleration as a share of the task's ``max_accel``."""
    return spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)


class Task:
    """What the environments share: how an action drives a vehicle and what a step earns.

    ``period_s`` is how long an action holds; ``max_accel`` (m/s²) scales actions; a step
    earns the mean speed of every vehicle (m/s) less ``accel_penalty`` × a² and
    ``collision_penalty`` per contact during it."""

    def __init__(self, period_s: float = 0.1, max_accel: float = 3.0,
                 accel_penalty: float = 0.1, collision_penalty: float = 100.0) -> None:
        self.period_ticks = max(1, round(period_s / DT_S))
        self.max_accel = float(max_accel)
        self.accel_penalty = float(accel_penalty)
        self.collision_penalty = float(collision_penalty)
        self.space = observation_space()

    def accel(self, action: Any) -> float:
        """The acceleration an action asks for, m/s²."""
        share = np.asarray(action, dtype=np.float64).reshape(-1)[0]
        return float(np.clip(share, -1.0, 1.0)) * self.max_accel

    def drive(self, sim: Sim, accel: dict[int, float]) -> None:
        """Gives each vehicle (by id) the target speed its acceleration reaches in a period,
        then runs the period."""
        v = sim.vehicles()
        speed_of = dict(zip(v["id"].tolist(), v["speed_mps"].tolist()))
        ids = [i for i in accel if i in speed_of]
        if ids:
            dt = self.period_ticks * DT_S
            sim.set_target(ids, [max(0.0, speed_of[i] + accel[i] * dt) for i in ids])
        sim.step(self.period_ticks)

    def observe(self, sim: Sim, ids: list[int]) -> tuple[dict[int, np.ndarray], float]:
        """Each present vehicle's observation (by id), and the mean speed of every vehicle."""
        v = sim.vehicles()
        mean = float(v["speed_mps"].mean()) if len(v["id"]) else 0.0
        speed_of = dict(zip(v["id"].tolist(), v["speed_mps"].tolist()))
        present = [i for i in ids if i in speed_of]
        out: dict[int, np.ndarray] = {}
        if present:
            lead = sim.leaders(present)
            for k, i in enumerate(present):
                speed = speed_of[i]
                gap = min(float(lead["gap_m"][k]), MAX_GAP_M)
                lead_speed = float(lead["speed_mps"][k]) if lead["id"][k] >= 0 else speed
                o = np.array([speed, max(gap, 0.0), lead_speed, mean], dtype=np.float32)
                out[i] = np.clip(o, self.space.low, self.space.high)
        return out, mean

    def reward(self, mean: float, accel: float, collisions: int) -> float:
        """What a step earns."""
        return float(mean - self.accel_penalty * accel * accel
                     - self.collision_penalty * collisions)


def check_render_mode(render_mode: str | None, metadata: dict[str, Any]) -> None:
    """Refuses a render mode the environment does not offer, naming those it does."""
    if render_mode is not None and render_mode not in metadata["render_modes"]:
        raise ValueError(
            f"render_mode {render_mode!r}: expected None or one of {metadata['render_modes']}"
        )


def episode_sim(level: Any, seed: int, overrides: dict[str, float],
                telemetry: str | os.PathLike[str] | None, warmup_s: float) -> Sim:
    """An episode's simulation: ``level`` on ``seed`` with ``overrides``, its telemetry to
    ``telemetry`` (none without it), run through ``warmup_s`` under the level's own drivers and
    signals."""
    sim = Sim(level, seed=seed, overrides=overrides,
              csv=telemetry if telemetry is not None else False)
    if warmup_s > 0:
        sim.run(warmup_s)
    return sim


def whole_level_frame(env: Any) -> np.ndarray | None:
    """An environment's ``render()`` of the whole level: its ``sim`` now, top down,
    ``render_size`` pixels, with ``render_mode="rgb_array"``; ``None`` without a render mode."""
    if env.render_mode is None:
        return None
    if env.sim is None:
        raise RuntimeError("call reset() before render()")
    return render_frame(env.sim, None, env.render_size, None)


def render_frame(sim: Sim, around: int | None, size: tuple[int, int],
                 width_m: float | None) -> np.ndarray:
    """A top-down frame of ``size`` pixels: ``width_m`` of ground centred on vehicle
    ``around``, or the whole level (without ``width_m``, or once that vehicle has gone)."""
    w, h = size
    region = None
    if width_m is not None and around is not None and around in set(sim.vehicles()["id"].tolist()):
        region = sim.region_around(around, width_m, w / h)
    return sim.render(w, h, "top", region)


#: Level-v0's observation types (or a callable, with ``observation_space``).
OBSERVATIONS = ("default", "kinematics", "lanes")
#: Level-v0's action types.
ACTIONS = ("acceleration", "continuous", "discrete")
#: The discrete action type's meta-actions, in index order (as highway-env's).
META_ACTIONS = ("lane_left", "idle", "lane_right", "faster", "slower")
#: A ``kinematics`` row's entries.
KINEMATICS = ("presence", "x", "y", "vx", "vy")
#: Distances and speeds of a ``kinematics`` observation are shares of these (then clipped to
#: -1..1), m and m/s.
KINEMATICS_RANGE_M = 100.0
KINEMATICS_SPEED_MPS = 40.0


def _agent_frame(sim: Sim, vehicle: int) -> tuple[dict[str, np.ndarray], int, float,
                                                  np.ndarray, np.ndarray] | None:
    """Every vehicle now, the agent's row, its heading and every vehicle's position relative
    to it (world axes), m; ``None`` once the agent has gone."""
    v = sim.vehicles()
    at = np.flatnonzero(v["id"] == vehicle)
    if len(at) == 0:
        return None
    k = int(at[0])
    return v, k, v["heading_rad"][k], v["x_m"] - v["x_m"][k], v["y_m"] - v["y_m"][k]


def kinematics(sim: Sim, vehicle: int, count: int) -> np.ndarray:
    """The ``count`` rows of a ``kinematics`` observation: the agent's own (presence 1, at the
    origin, its speed along x), then its ``count - 1`` nearest vehicles', nearest first (ties by
    id), each relative to the agent in its frame (x ahead, y to its left), normalised by
    :data:`KINEMATICS_RANGE_M` and :data:`KINEMATICS_SPEED_MPS` and clipped; rows for vehicles
    that are not there are zeros."""
    out = np.zeros((count, len(KINEMATICS)), dtype=np.float32)
    frame = _agent_frame(sim, vehicle)
    if frame is None:
        return out
    v, k, h, dx, dy = frame
    c, s = np.cos(-h), np.sin(-h)
    vx = v["speed_mps"] * np.cos(v["heading_rad"])
    vy = v["speed_mps"] * np.sin(v["heading_rad"])
    dvx, dvy = vx - vx[k], vy - vy[k]
    rows = np.stack([np.ones_like(dx), c * dx - s * dy, s * dx + c * dy,
                     c * dvx - s * dvy, s * dvx + c * dvy], axis=1)
    rows[:, 1:3] /= KINEMATICS_RANGE_M
    rows[:, 3:5] /= KINEMATICS_SPEED_MPS
    out[0] = [1.0, 0.0, 0.0, v["speed_mps"][k] / KINEMATICS_SPEED_MPS, 0.0]
    others = [i for i in np.lexsort((v["id"], np.hypot(dx, dy))) if i != k][: count - 1]
    if others:
        out[1:1 + len(others)] = rows[others]
    return np.clip(out, -1.0, 1.0)


#: The ``lanes`` observation's channels, in order.
LANES = ("presence", "vx")
#: Its rows: lanes of this width, m, centred on the agent's.
LANE_WIDTH_M = 3.5
#: Its columns: cells of this length, m, from :data:`LANES_BEHIND_M` behind the agent to
#: :data:`LANES_AHEAD_M` ahead.
LANES_CELL_M = 5.0
LANES_BEHIND_M = 50.0
LANES_AHEAD_M = 100.0


def lanes_grid(sim: Sim, vehicle: int, lanes: int) -> np.ndarray:
    """A ``lanes`` observation: an occupancy grid in the agent's frame, shape ``(2, lanes,
    cells)``. Row ``r`` is the lane ``(lanes - 1) // 2 - r`` lanes to the agent's left (so the
    leftmost row first and the agent's lane in the middle), :data:`LANE_WIDTH_M` wide; column
    ``c`` the cell :data:`LANES_CELL_M` long starting ``c`` cells after
    :data:`LANES_BEHIND_M` behind the agent's centre. Channel 0 is 1 where another vehicle's
    centre is, channel 1 that vehicle's speed along the agent's heading relative to the
    agent's, over :data:`KINEMATICS_SPEED_MPS` (clipped to -1..1); the agent's own cell shows
    it with relative speed 0. Zeros once the agent has gone."""
    cells = int(round((LANES_AHEAD_M + LANES_BEHIND_M) / LANES_CELL_M))
    out = np.zeros((len(LANES), lanes, cells), dtype=np.float32)
    frame = _agent_frame(sim, vehicle)
    if frame is None:
        return out
    v, k, h, dx, dy = frame
    c, s = np.cos(-h), np.sin(-h)
    ahead, left = c * dx - s * dy, s * dx + c * dy
    vx = v["speed_mps"] * np.cos(v["heading_rad"] - h)
    row = (lanes - 1) // 2 - np.floor(left / LANE_WIDTH_M + 0.5).astype(np.int64)
    col = np.floor((ahead + LANES_BEHIND_M) / LANES_CELL_M).astype(np.int64)
    inside = (row >= 0) & (row < lanes) & (col >= 0) & (col < cells)
    # The nearest vehicle in a cell shows: written farthest first.
    for i in np.argsort(-np.hypot(dx, dy), kind="stable"):
        if inside[i]:
            out[0, row[i], col[i]] = 1.0
            out[1, row[i], col[i]] = np.clip((vx[i] - vx[k]) / KINEMATICS_SPEED_MPS, -1.0, 1.0)
    return out


#: The reward's terms, each a number per step, weighted and summed (see :class:`LevelEnv`).
REWARD_TERMS = ("mean_speed", "agent_speed", "accel_sq", "collisions", "lane_change",
                "close_headway")

#: A time headway to the leader below this is ``close_headway``, s.
CLOSE_HEADWAY_S = 1.0


class LevelEnv(gym.Env):
    """One vehicle of ``level`` — the lowest-numbered one of driver profile ``profile`` — driven
    by the agent; everything else by the level's drivers.

    * Observation (float32): the agent's speed, the bumper gap to its leader (``MAX_GAP_M``
      without one within range), the leader's speed (the agent's own without one) and the mean
      speed of every vehicle, all in m and m/s.
    * Action: a target acceleration as a share of ``max_accel`` (-1..1, so -3..3 m/s² by
      default): the shared controller drives at the speed it gives (never below 0) for
      ``period_s``.
    * Reward per step: the mean speed of every vehicle, m/s, less ``accel_penalty`` × a² and
      ``collision_penalty`` per contact or guardrail hit during the step. ``reward_weights``
      makes it any weighted sum of the terms in :data:`REWARD_TERMS` (``info["reward_terms"]``
      gives each every step): ``mean_speed`` (m/s, every vehicle), ``agent_speed`` (m/s),
      ``accel_sq`` (the agent's acceleration squared, m²/s⁴), ``collisions`` (contacts and
      guardrail hits during the step), ``lane_change`` (1 when the agent's lane changed),
      ``close_headway`` (1 when the agent follows its leader closer than
      :data:`CLOSE_HEADWAY_S`). The defaults are ``{"mean_speed": 1, "accel_sq":
      -accel_penalty, "collisions": -collision_penalty}``; weights given replace those of
      their terms, and the others stay.
    * An episode: ``warmup_s`` with the vehicle under its own driver, then ``episode_s`` under
      the agent (truncated then). It ends (terminated) if the agent's vehicle leaves the level.
    * On a level with no vehicle of the profile at the start (spawners only), the agent is the
      first vehicle of the profile spawned after the warm-up; with ``agent_spawner``, the first
      that spawner spawns after it; with ``agent_road``, the newest of the profile on that road
      after it.

    ``reset(seed=…)`` is deterministic: the same seed gives the same episode for the same
    actions.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    #: Size of a rendered frame, pixels.
    render_size = (640, 480)
    #: Width of ground a frame shows around the agent, m (``None``: the whole level).
    render_width_m: float | None = 120.0

    def __init__(
        self,
        level: str = "stern_ring",
        profile: str = "autonomous",
        warmup_s: float = 60.0,
        episode_s: float = 240.0,
        overrides: dict[str, float] | None = None,
        agent_road: str | None = None,
        agent_spawner: str | None = None,
        render_mode: str | None = None,
        render_size: tuple[int, int] | None = None,
        render_width_m: float | None | object = DEFAULT,
        telemetry: str | os.PathLike[str] | None = None,
        observation: str | Any = "default",
        observation_space: spaces.Space | None = None,
        vehicles_count: int = 5,
        action: str = "acceleration",
        speed_step_mps: float = 2.5,
        lanes_count: int = 5,
        reward_weights: dict[str, float] | None = None,
        **task: float,
    ) -> None:
        """``observation`` is ``"default"``, ``"kinematics"`` (``vehicles_count`` rows, see
        :func:`kinematics`), ``"lanes"`` (an occupancy grid ``lanes_count`` lanes wide, see
        :func:`lanes_grid`) or a callable ``f(sim, vehicle) -> array`` with its
        ``observation_space``; ``action`` is ``"acceleration"``, ``"continuous"`` (throttle and
        steering as :meth:`Sim.set_controls`) or ``"discrete"`` (:data:`META_ACTIONS`, the
        target speed moved by ``speed_step_mps``). ``task`` holds :class:`Task`'s keywords: ``period_s``, ``max_accel``,
        ``accel_penalty``, ``collision_penalty``. ``render_mode="rgb_array"`` makes
        :meth:`render` return the scene around the agent as RGB bytes, ``render_size``
        ``(width, height)`` pixels, ``render_width_m`` of ground across (``None``: the whole
        level); left out, the class's defaults. ``telemetry``: a CSV path each episode's
        telemetry streams to (overwritten at every reset); none is written without it."""
        check_render_mode(render_mode, self.metadata)
        if render_size is not None:
            self.render_size = render_size_of(render_size)
        if render_width_m is not DEFAULT:
            self.render_width_m = render_width_of(render_width_m)
        self.level = level
        self.profile = profile
        self.agent_road = agent_road
        self.agent_spawner = agent_spawner
        if agent_spawner is not None and agent_road is not None:
            raise ValueError("give agent_road or agent_spawner, not both")
        if agent_spawner is not None:
            spawner_road(level, agent_spawner)
        self.telemetry = telemetry
        self.warmup_s = float(warmup_s)
        self.episode_s = float(episode_s)
        self.task = Task(**task)
        self.overrides = dict(overrides or {})
        self.render_mode = render_mode
        if not (callable(observation) or observation in OBSERVATIONS):
            raise ValueError(f"observation {observation!r}: expected one of "
                             f"{', '.join(OBSERVATIONS)} or a callable f(sim, vehicle)")
        if callable(observation) and observation_space is None:
            raise ValueError("a callable observation needs its observation_space")
        if action not in ACTIONS:
            raise ValueError(f"action {action!r}: expected one of {', '.join(ACTIONS)}")
        if int(vehicles_count) < 1:
            raise ValueError(f"vehicles_count={vehicles_count!r}: expected 1 or more")
        if int(lanes_count) < 1:
            raise ValueError(f"lanes_count={lanes_count!r}: expected 1 or more")
        self.lanes_count = int(lanes_count)
        self._custom_weights = bool(reward_weights)
        self.reward_weights = {
            "mean_speed": 1.0,
            "accel_sq": -self.task.accel_penalty,
            "collisions": -self.task.collision_penalty,
        }
        for term, weight in (reward_weights or {}).items():
            if term not in REWARD_TERMS:
                raise ValueError(f"reward_weights: unknown term {term!r}; the terms are "
                                 f"{', '.join(REWARD_TERMS)}")
            w = float(weight)
            if not np.isfinite(w):
                raise ValueError(f"reward_weights[{term!r}] = {weight!r}: expected a finite number")
            self.reward_weights[term] = w
        self.observation_type = observation
        self.vehicles_count = int(vehicles_count)
        self.action_type = action
        self.speed_step_mps = float(speed_step_mps)
        if action == "acceleration":
            self.action_space = action_space()
        elif action == "continuous":
            self.action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        else:
            self.action_space = spaces.Discrete(len(META_ACTIONS))
        if callable(observation):
            self.observation_space = observation_space
        elif observation == "kinematics":
            self.observation_space = spaces.Box(
                -1.0, 1.0, shape=(self.vehicles_count, len(KINEMATICS)), dtype=np.float32)
        elif observation == "lanes":
            cells = int(round((LANES_AHEAD_M + LANES_BEHIND_M) / LANES_CELL_M))
            self.observation_space = spaces.Box(
                -1.0, 1.0, shape=(len(LANES), self.lanes_count, cells), dtype=np.float32)
        else:
            self.observation_space = _default_observation_space()
        self._target_mps = 0.0
        self.sim: Sim | None = None
        self.agent: int | None = None
        self._steps = 0
        self._collisions = 0

    def _observe(self) -> tuple[np.ndarray, float, bool]:
        obs, mean = self.task.observe(self.sim, [self.agent])
        present = self.agent in obs
        if self.observation_type == "kinematics":
            return kinematics(self.sim, self.agent, self.vehicles_count), mean, present
        if self.observation_type == "lanes":
            return lanes_grid(self.sim, self.agent, self.lanes_count), mean, present
        if callable(self.observation_type):
            return np.asarray(self.observation_type(self.sim, self.agent)), mean, present
        if not present:
            return np.array([0.0, MAX_GAP_M, 0.0, mean], dtype=np.float32), mean, False
        return obs[self.agent], mean, True

    def _speed(self) -> tuple[float, int]:
        """The agent's speed, m/s, and lane (0 and 0 once it has gone)."""
        v = self.sim.vehicles()
        at = np.flatnonzero(v["id"] == self.agent)
        if len(at) == 0:
            return 0.0, 0
        return float(v["speed_mps"][at[0]]), int(v["lane"][at[0]])

    def _act(self, action: Any) -> float:
        """Applies ``action`` for a period; the acceleration the reward's penalty takes."""
        if self.action_type == "acceleration":
            a = self.task.accel(action)
            self.task.drive(self.sim, {self.agent: a})
            return a
        before, lane = self._speed()
        dt = self.task.period_ticks * DT_S
        present = self.agent in set(self.sim.vehicles()["id"].tolist())
        if self.action_type == "continuous":
            throttle, steering = np.clip(np.asarray(action, dtype=np.float64).reshape(-1)[:2],
                                         -1.0, 1.0)
            if present:
                self.sim.set_controls([self.agent], throttle, steering)
        else:
            meta = META_ACTIONS[int(np.asarray(action).reshape(-1)[0])]
            if meta == "faster":
                self._target_mps = min(self._target_mps + self.speed_step_mps, 40.0)
            elif meta == "slower":
                self._target_mps = max(self._target_mps - self.speed_step_mps, 0.0)
            want = lane + {"lane_left": 1, "lane_right": -1}.get(meta, 0)
            if present:
                try:
                    self.sim.set_target([self.agent], self._target_mps, [max(want, 0)])
                except ValueError:  # no lane there: keep its own
                    self.sim.set_target([self.agent], self._target_mps, [-1])
        self.sim.step(self.task.period_ticks)
        after, _ = self._speed()
        return (after - before) / dt

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        sim_seed = int(self.np_random.integers(0, 2**31 - 1))
        self.sim = Sim(self.level, seed=sim_seed, overrides=self.overrides,
                       csv=self.telemetry if self.telemetry is not None else False)
        self.sim.step(1)
        if self.agent_road is None and self.agent_spawner is None:
            v = self.sim.vehicles()
            mine = v["id"][v["profile"] == self.profile]
            if len(mine):
                self.agent = int(mine.min())
                if self.warmup_s > 0:
                    self.sim.run(self.warmup_s)
            else:
                # A level that starts empty: the first of the profile spawned after the warm-up.
                if self.warmup_s > 0:
                    self.sim.run(self.warmup_s)
                self.agent = first_spawned(self.sim, self.profile, None, self.level)
        elif self.agent_spawner is not None:
            if self.warmup_s > 0:
                self.sim.run(self.warmup_s)
            self.agent = first_spawned(self.sim, self.profile, self.agent_spawner, self.level)
        else:
            if self.warmup_s > 0:
                self.sim.run(self.warmup_s)
            self.agent = self._newest_on_road()
        self._steps = 0
        self._collisions = self.sim.collisions
        self._target_mps = self._speed()[0]
        obs, _, _ = self._observe()
        return obs, {"time_s": self.sim.time_s, "vehicle": self.agent, "seed": sim_seed}

    def _newest_on_road(self) -> int:
        """The first vehicle of the profile to come onto ``agent_road`` (waiting up to 120 s
        for one)."""
        for _ in range(1200):
            v = self.sim.vehicles()
            here = v["id"][(v["road"] == self.agent_road) & (v["profile"] == self.profile)]
            if len(here):
                return int(here.max())
            self.sim.step(12)
        raise ValueError(
            f"{self.level}: no vehicle of driver profile `{self.profile}` came onto road "
            f"`{self.agent_road}` within 120 s"
        )

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self.sim is None:
            raise RuntimeError("call reset() before step()")
        _, lane_before = self._speed()
        a = self._act(action)
        self._steps += 1
        obs, mean, present = self._observe()
        collisions = self.sim.collisions
        new = collisions - self._collisions
        self._collisions = collisions
        terms = self._reward_terms(mean, a, new, lane_before, present)
        if self._custom_weights:
            reward = sum(w * terms[t] for t, w in self.reward_weights.items())
        else:  # the task's own formula, to the last bit
            reward = self.task.reward(mean, a, new)
        truncated = self._steps * self.task.period_ticks * DT_S >= self.episode_s - 1e-9
        info = {"time_s": self.sim.time_s, "collisions": new, "mean_speed_mps": mean,
                "reward_terms": terms}
        return obs, float(reward), not present, bool(truncated and present), info

    def _reward_terms(self, mean: float, accel: float, collisions: int, lane_before: int,
                      present: bool) -> dict[str, float]:
        """Every term of :data:`REWARD_TERMS` for the step just run."""
        speed, lane = self._speed()
        close = 0.0
        if present:
            lead = self.sim.leaders([self.agent])
            if lead["id"][0] >= 0 and speed > 0.0:
                close = float(float(lead["gap_m"][0]) / speed < CLOSE_HEADWAY_S)
        return {
            "mean_speed": float(mean),
            "agent_speed": float(speed),
            "accel_sq": float(accel * accel),
            "collisions": float(collisions),
            "lane_change": float(present and lane != lane_before),
            "close_headway": close,
        }

    def render(self) -> np.ndarray | None:
        """With ``render_mode="rgb_array"``: the scene now, top down, ``render_size`` pixels,
        ``render_width_m`` of ground centred on the agent (the whole level once it has left, or
        with ``render_width_m = None``). ``None`` without a render mode."""
        if self.render_mode is None:
            return None
        if self.sim is None:
            raise RuntimeError("call reset() before render()")
        return render_frame(self.sim, self.agent, self.render_size, self.render_width_m)


def spawner_road(level: Any, spawner: str) -> str:
    """The road spawner ``spawner`` of ``level`` puts its vehicles on, or ``ValueError``
    naming the level's spawners."""
    from .level import Level

    spawners = Level(level).to_dict().get("spawners", [])
    for sp in spawners:
        if sp["name"] == spawner:
            return sp["road"]
    names = ", ".join(sp["name"] for sp in spawners) or "none"
    raise ValueError(f"{level}: no spawner `{spawner}`; its spawners are: {names}")


def first_spawned(sim: Sim, profile: str, spawner: str | None, level: Any,
                  within_s: float = 120.0) -> int:
    """The first vehicle of ``profile`` to appear from now on (from ``spawner`` when given: on
    its road), stepping the simulation until it does (``ValueError`` after ``within_s``)."""
    road = None if spawner is None else spawner_road(level, spawner)
    known = set(sim.vehicles()["id"].tolist())
    for _ in range(round(within_s * 10)):
        sim.step(12)
        v = sim.vehicles()
        new = ~np.isin(v["id"], list(known)) & (v["profile"] == profile)
        if road is not None:
            new &= v["road"] == road
        if new.any():
            return int(v["id"][new].min())
        known.update(v["id"][v["profile"] != profile].tolist())
        if road is not None:
            known.update(v["id"][v["road"] != road].tolist())
    where = "" if spawner is None else f" from spawner `{spawner}`"
    raise ValueError(f"{level}: no vehicle of driver profile `{profile}` was spawned{where} "
                     f"within {within_s:.0f} s of the warm-up's end")


class MergeEnv(LevelEnv):
    """``flockway/Merge-v0``: the merging car of ``on_ramp`` — the newest car on the ramp after
    the warm-up — driven along the ramp, through the acceleration lane onto the motorway and
    on until it leaves the level (terminated) or 60 s have passed (truncated). Its lane is its
    route's: the agent chooses its speed, the car merges where its lane ends."""

    def __init__(self, **kwargs: Any) -> None:
        kwargs.setdefault("level", "on_ramp")
        kwargs.setdefault("profile", "autonomous")
        kwargs.setdefault("agent_road", "ramp")
        kwargs.setdefault("warmup_s", 60.0)
        kwargs.setdefault("episode_s", 60.0)
        super().__init__(**kwargs)


class RingWaveEnv(LevelEnv):
    """``flockway/RingWave-v0``: the Stern ring (one autonomous car among 21 human-like drivers
    on the 230 m Sugiyama ring) with the autonomous car as the agent. Its frames show the
    whole ring."""

    render_width_m = None

    def __init__(self, **kwargs: Any) -> None:
        kwargs.setdefault("level", "stern_ring")
        kwargs.setdefault("profile", "autonomous")
        super().__init__(**kwargs)


def register_all() -> None:
    """Registers the environments with gymnasium (done on ``import flockway``)."""
    for env_id, entry in (
        ("flockway/RingWave-v0", "flockway.envs:RingWaveEnv"),
        ("flockway/Merge-v0", "flockway.envs:MergeEnv"),
        ("flockway/Level-v0", "flockway.envs:LevelEnv"),
        ("flockway/SignalControl-v0", "flockway.signals:SignalControlEnv"),
    ):
        if env_id not in gym.registry:
            gym.register(id=env_id, entry_point=entry)
