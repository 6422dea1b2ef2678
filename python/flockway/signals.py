"""Traffic-signal control as sumo-rl poses it: an agent per signalised junction chooses the next
green phase every ``delta_time_s``, with an amber of ``yellow_time_s`` and an all-red of
``all_red_s`` between greens and a minimum green of ``min_green_s``.

``flockway/SignalControl-v0`` controls one junction (the level's first signalised one, or
``junction=NAME``); :func:`flockway.multi.signal_parallel_env` (PettingZoo) controls every
signalised junction of a level at once, one agent each. :func:`max_pressure` is the hand-written
baseline (the max-pressure rule of Varaiya, 2013) and ``fixed_time=True`` leaves the level's own
program running, for comparison. This module needs gymnasium only; the PettingZoo twin lives in
:mod:`flockway.multi`.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any, Callable

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from .envs import check_render_mode, episode_sim, render_size_of, whole_level_frame
from .sim import DT_S, Sim

#: A vehicle takes this much of a lane, m (length and standstill gap): the jam density that
#: scales the observed densities and queues to 0..1, as sumo-rl's.
VEHICLE_SPACE_M = 7.5

#: The rewards a junction's agent can be given by name.
REWARDS = ("diff-waiting-time", "queue", "pressure")


def green_phases(phases: list[tuple[float, str]]) -> list[str]:
    """The green phases of a program: the states with a green and no amber, each once, in the
    program's order."""
    out: list[str] = []
    for _, state in phases:
        if any(c in "Gg" for c in state) and not any(c in "yY" for c in state) and state not in out:
            out.append(state)
    return out


class Junction:
    """One signalised junction under an agent: its green phases, what it observes, what a step
    earns, and how an action sets its signal.

    * Observation (float32, 0..1): the current green phase one-hot, whether the minimum green
      has passed (1.0) or not, each incoming lane's density (vehicles over the lane's length in
      :data:`VEHICLE_SPACE_M`) and queue (halting vehicles, the same scale), clipped to 1.
    * Action: the index of the next green phase.
    * Reward (per decision): ``diff-waiting-time`` (the drop in the summed waiting of the
      vehicles on its incoming lanes since the last decision, s / 100), ``queue`` (minus the
      halting vehicles on them), ``pressure`` (minus vehicles on the incoming lanes less those
      on the outgoing ones) or a callable ``f(junction, sim) -> float``.
    """

    def __init__(self, sim: Sim, name: str, min_green_s: float, yellow_time_s: float,
                 reward: str | Callable[["Junction", Sim], float],
                 all_red_s: float = 0.0) -> None:
        sig = next((s for s in sim.signals() if s["junction"] == name), None)
        if sig is None:
            names = [s["junction"] for s in sim.signals()]
            raise ValueError(f"{sim.level}: no signalised junction `{name}`; the signalised "
                             f"junctions are: {', '.join(names) or 'none'}")
        check_reward(reward)
        self.name = name
        self.greens = green_phases(sig["phases"])
        if not self.greens:
            raise ValueError(f"junction `{name}`: its program has no green phase")
        self.connections = sig["connections"]
        self.min_green_s = float(min_green_s)
        self.yellow_time_s = float(yellow_time_s)
        self.all_red_s = float(all_red_s)
        self.reward_fn = reward
        lanes = sim.junctions()
        mine = lanes["junction"] == name
        self.in_lanes = list(zip(lanes["road"][mine].tolist(), lanes["lane"][mine].tolist()))
        self.in_length_m = lanes["length_m"][mine].astype(np.float64)
        self.out_lanes = sorted({(c[2], c[3]) for c in self.connections})
        self.green = self.greens.index(sig["state"]) if sig["state"] in self.greens else 0
        self.green_since_s = sim.time_s
        self.last_waiting_s = float(lanes["waiting_s"][mine].sum())

    @property
    def observation_size(self) -> int:
        return len(self.greens) + 1 + 2 * len(self.in_lanes)

    def start(self, sim: Sim) -> None:
        """Takes the junction over: its first green phase now."""
        self.green = 0
        sim.set_signal_state(self.name, self.greens[0])
        self.green_since_s = sim.time_s

    def act(self, sim: Sim, action: int) -> None:
        """Switches to green phase ``action`` (through an amber and an all-red) once the current
        one has had its minimum green; otherwise keeps it."""
        a = int(action)
        if not 0 <= a < len(self.greens):
            raise ValueError(f"junction `{self.name}`: action {action!r}: expected a green "
                             f"phase 0 to {len(self.greens) - 1}")
        if a == self.green or not self.min_green_passed(sim):
            return
        sim.set_signal_state(self.name, self.greens[a], amber_s=self.yellow_time_s,
                             all_red_s=self.all_red_s)
        self.green = a
        self.green_since_s = sim.time_s + self.yellow_time_s + self.all_red_s

    def min_green_passed(self, sim: Sim) -> bool:
        return sim.time_s - self.green_since_s >= self.min_green_s - 1e-9

    def _lanes(self, sim: Sim, lanes: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
        lanes = sim.junctions() if lanes is None else lanes
        mine = lanes["junction"] == self.name
        return {k: v[mine] for k, v in lanes.items()}

    def observe(self, sim: Sim, lanes: dict[str, np.ndarray] | None = None) -> np.ndarray:
        mine = self._lanes(sim, lanes)
        room = np.maximum(self.in_length_m / VEHICLE_SPACE_M, 1.0)
        one_hot = np.zeros(len(self.greens))
        one_hot[self.green] = 1.0
        obs = np.concatenate([
            one_hot,
            [1.0 if self.min_green_passed(sim) else 0.0],
            np.minimum(mine["vehicles"] / room, 1.0),
            np.minimum(mine["halting"] / room, 1.0),
        ])
        return obs.astype(np.float32)

    def reward(self, sim: Sim, lanes: dict[str, np.ndarray] | None = None,
               counts: dict[tuple[str, int], int] | None = None) -> float:
        if callable(self.reward_fn):
            return float(self.reward_fn(self, sim))
        mine = self._lanes(sim, lanes)
        if self.reward_fn == "diff-waiting-time":
            waiting = float(mine["waiting_s"].sum())
            r = (self.last_waiting_s - waiting) / 100.0
            self.last_waiting_s = waiting
            return r
        if self.reward_fn == "pressure":
            counts = lane_counts(sim) if counts is None else counts
            inflow = sum(counts.get(lane, 0) for lane in self.in_lanes)
            outflow = sum(counts.get(lane, 0) for lane in self.out_lanes)
            return -float(inflow - outflow)
        return -float(mine["halting"].sum())


def lane_counts(sim: Sim) -> dict[tuple[str, int], int]:
    """Vehicles per ``(road, lane)`` now."""
    v = sim.vehicles()
    out: dict[tuple[str, int], int] = {}
    for road, lane in zip(v["road"].tolist(), v["lane"].tolist()):
        out[(road, lane)] = out.get((road, lane), 0) + 1
    return out


def max_pressure(junction: Junction, sim: Sim,
                 counts: dict[tuple[str, int], int] | None = None) -> int:
    """The max-pressure choice: the green phase whose movements have the most vehicles waiting
    to go less the vehicles on the lanes they go to (each movement counted once per green
    letter); ties go to the current phase, then the lowest index."""
    counts = lane_counts(sim) if counts is None else counts
    best, best_p = junction.green, -np.inf
    for k in [junction.green] + [i for i in range(len(junction.greens)) if i != junction.green]:
        p = 0.0
        for letter, (fr, fl, to, tl) in zip(junction.greens[k], junction.connections):
            if letter in "Gg":
                p += counts.get((fr, fl), 0) - counts.get((to, tl), 0)
        if p > best_p + 1e-9:
            best, best_p = k, p
    return best


@dataclass(frozen=True)
class Timing:
    """How a controlled junction's decisions are timed, s (checked: all from 0, the decision
    interval and the episode above 0)."""

    delta_time_s: float = 5.0
    yellow_time_s: float = 3.0
    all_red_s: float = 2.0
    min_green_s: float = 10.0
    warmup_s: float = 60.0
    episode_s: float = 600.0

    def __post_init__(self) -> None:
        for key, value in vars(self).items():
            if not (float(value) >= 0.0 and np.isfinite(value)):
                raise ValueError(f"{key}={value!r}: expected seconds from 0")
        if self.delta_time_s <= 0 or self.episode_s <= 0:
            raise ValueError("delta_time_s and episode_s must be above 0")

    @property
    def delta_ticks(self) -> int:
        """Simulation steps between decisions."""
        return max(1, round(self.delta_time_s / DT_S))

    def junction(self, sim: Sim, name: str,
                 reward: str | Callable[[Junction, Sim], float]) -> Junction:
        """Junction ``name`` of ``sim`` under an agent with these timings."""
        return Junction(sim, name, self.min_green_s, self.yellow_time_s, reward,
                        self.all_red_s)

    def done(self, decisions: int) -> bool:
        """Whether ``decisions`` decisions fill the episode."""
        return decisions * self.delta_ticks * DT_S >= self.episode_s - 1e-9


def check_reward(reward: Any) -> None:
    """Refuses a reward that is neither a name in :data:`REWARDS` nor a callable."""
    if not (callable(reward) or reward in REWARDS):
        raise ValueError(f"reward {reward!r}: expected one of {', '.join(REWARDS)} or a "
                         "callable f(junction, sim) -> float")


def configure(env: Any, level: str, timing: Timing, reward: Any, fixed_time: bool,
              overrides: dict[str, float] | None, telemetry: Any, render_mode: str | None,
              render_size: tuple[int, int] | None) -> None:
    """The keywords both signal-control environments take, checked and kept on ``env``."""
    check_render_mode(render_mode, env.metadata)
    if render_size is not None:
        env.render_size = render_size_of(render_size)
    env.timing = timing
    check_reward(reward)
    env.level = level
    env.reward_spec = reward
    env.fixed_time = bool(fixed_time)
    env.overrides = dict(overrides or {})
    env.telemetry = telemetry
    env.render_mode = render_mode


class SignalControlEnv(gym.Env):
    """``flockway/SignalControl-v0``: one signalised junction of ``level`` driven by the agent
    (the first one, or ``junction``); the others keep their programs.

    See :class:`Junction` for the observation, action and rewards. Every ``delta_time_s`` the
    agent picks the next green phase; a change goes through ``yellow_time_s`` of amber for the
    movements losing green, then ``all_red_s`` of red for every movement that changes, and
    happens only once the current green has lasted ``min_green_s``.
    An episode is ``warmup_s`` under the level's program, then ``episode_s`` (truncated then).
    ``fixed_time=True`` ignores the actions and leaves the level's program running: the
    baseline. ``info`` gives ``time_s``, the junction's ``waiting_s`` and ``halting``, and the
    whole network's ``system_waiting_s`` (mean waiting of the vehicles on every junction's
    incoming lanes) and ``system_halting``.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 2}
    render_size = (640, 480)

    def __init__(
        self,
        level: str = "signal_grid",
        junction: str | None = None,
        delta_time_s: float = 5.0,
        yellow_time_s: float = 3.0,
        all_red_s: float = 2.0,
        min_green_s: float = 10.0,
        warmup_s: float = 60.0,
        episode_s: float = 600.0,
        reward: str | Callable[[Junction, Sim], float] = "diff-waiting-time",
        fixed_time: bool = False,
        overrides: dict[str, float] | None = None,
        telemetry: str | os.PathLike[str] | None = None,
        render_mode: str | None = None,
        render_size: tuple[int, int] | None = None,
    ) -> None:
        configure(self, level, Timing(delta_time_s, yellow_time_s, all_red_s, min_green_s,
                                      warmup_s, episode_s),
                  reward, fixed_time, overrides, telemetry, render_mode, render_size)
        # The spaces come from the junction: read them off a first look at the level.
        probe = Sim(level, overrides=self.overrides, csv=False)
        self.junction_name = junction if junction is not None else _first_signal(probe)
        j = self.timing.junction(probe, self.junction_name, reward)
        self.action_space = spaces.Discrete(len(j.greens))
        self.observation_space = spaces.Box(0.0, 1.0, shape=(j.observation_size,),
                                            dtype=np.float32)
        self.sim: Sim | None = None
        self.junction: Junction | None = None
        self._steps = 0

    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        sim_seed = int(self.np_random.integers(0, 2**31 - 1))
        self.sim = episode_sim(self.level, sim_seed, self.overrides, self.telemetry,
                               self.timing.warmup_s)
        self.junction = self.timing.junction(self.sim, self.junction_name, self.reward_spec)
        if not self.fixed_time:
            self.junction.start(self.sim)
        self._steps = 0
        lanes = self.sim.junctions()
        info = self._info(lanes)
        info["seed"] = sim_seed
        return self.junction.observe(self.sim, lanes), info

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self.sim is None or self.junction is None:
            raise RuntimeError("call reset() before step()")
        if not self.fixed_time:
            self.junction.act(self.sim, int(np.asarray(action).reshape(-1)[0]))
        self.sim.step(self.timing.delta_ticks)
        self._steps += 1
        lanes = self.sim.junctions()
        obs = self.junction.observe(self.sim, lanes)
        reward = self.junction.reward(self.sim, lanes)
        truncated = self.timing.done(self._steps)
        return obs, reward, False, bool(truncated), self._info(lanes)

    def _info(self, lanes: dict[str, np.ndarray]) -> dict[str, Any]:
        mine = lanes["junction"] == self.junction_name
        return {
            "time_s": self.sim.time_s,
            "waiting_s": float(lanes["waiting_s"][mine].sum()),
            "halting": int(lanes["halting"][mine].sum()),
            **system_measures(lanes),
        }

    def render(self) -> np.ndarray | None:
        """With ``render_mode="rgb_array"``: the whole level now, top down."""
        return whole_level_frame(self)


def system_measures(lanes: dict[str, np.ndarray]) -> dict[str, float]:
    """Over every junction's incoming lanes: the vehicles' mean waiting, s, and how many halt."""
    vehicles = int(lanes["vehicles"].sum())
    return {
        "system_waiting_s": float(lanes["waiting_s"].sum()) / vehicles if vehicles else 0.0,
        "system_halting": int(lanes["halting"].sum()),
    }


def _first_signal(sim: Sim) -> str:
    signals = sim.signals()
    if not signals:
        raise ValueError(f"{sim.level}: the level has no signalised junction to control")
    return signals[0]["junction"]
