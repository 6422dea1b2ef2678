"""PettingZoo ParallelEnvs: every vehicle of one driver profile is an agent
(:func:`parallel_env`), or every signalised junction of a level (:func:`signal_parallel_env`)."""

from __future__ import annotations

import functools
import os
from typing import Any, Callable

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from .envs import (
    Task,
    action_space,
    check_render_mode,
    episode_sim,
    observation_space,
    render_size_of,
    whole_level_frame,
)
from .signals import Junction, Timing, configure, lane_counts, system_measures
from .sim import DT_S, Sim


class LevelParallelEnv(ParallelEnv):
    """Every vehicle of driver profile ``profile`` on ``level`` is an agent (``"vehicle_ID"``),
    all deciding at once; the level's other vehicles keep their own drivers.

    Each agent observes what ``flockway/Level-v0``'s agent does (its speed, the gap to its
    leader, the leader's speed, the mean speed of every vehicle) and acts the same way (a target
    acceleration as a share of ``max_accel``, held for ``period_s``). Its reward per step is the
    mean speed of every vehicle, m/s, less ``accel_penalty`` × its own a², less
    ``collision_penalty`` per contact in the level during the step (shared: a crash is
    everyone's). The agents are the profile's vehicles after the warm-up, joined by each vehicle
    of the profile spawned during the episode (it appears in ``agents`` and the observations
    after the step it was spawned in); one that leaves the level is done (terminated); the
    others are truncated after ``episode_s``. A newcomer's first reward is 0. ``possible_agents`` is every vehicle the level
    can have by the episode's end: those at the start and as many as its spawners can spawn
    (at their shortest intervals, or their listed departures)."""

    metadata = {
        "render_modes": ["rgb_array"],
        "name": "flockway_level_parallel_v0",
        "render_fps": 10,
    }

    #: Size of a rendered frame, pixels.
    render_size = (640, 480)

    def __init__(
        self,
        level: str = "sugiyama_ring",
        profile: str = "human",
        warmup_s: float = 30.0,
        episode_s: float = 120.0,
        overrides: dict[str, float] | None = None,
        render_mode: str | None = None,
        render_size: tuple[int, int] | None = None,
        telemetry: str | os.PathLike[str] | None = None,
        **task: float,
    ) -> None:
        """``task`` holds :class:`flockway.envs.Task`'s keywords: ``period_s``,
        ``max_accel``, ``accel_penalty``, ``collision_penalty``."""
        check_render_mode(render_mode, self.metadata)
        if render_size is not None:
            self.render_size = render_size_of(render_size)
        self.level, self.profile = level, profile
        # Each episode's telemetry CSV (overwritten at every reset); none without a path.
        self.telemetry = telemetry
        self.warmup_s, self.episode_s = float(warmup_s), float(episode_s)
        self.task = Task(**task)
        self.overrides = dict(overrides or {})
        self.render_mode = render_mode
        # The vehicles a level starts with, found by a short probe (the same for every seed),
        # and room for every one its spawners can add by the episode's end.
        probe = Sim(level, overrides=self.overrides, csv=False)
        probe.step(1)
        v = probe.vehicles()
        ids = sorted(int(i) for i in v["id"][v["profile"] == profile])
        first_new = int(v["id"].max()) + 1 if len(v["id"]) else 0
        most = most_spawned(level, self.warmup_s + self.episode_s + 1.0)
        if not ids and most == 0:
            raise ValueError(f"{level}: no vehicle of driver profile `{profile}` at the start "
                             "and no spawner to bring one")
        ids += list(range(first_new, first_new + most))
        self.possible_agents = [f"vehicle_{i}" for i in ids]
        self.agents: list[str] = []
        self._ids = dict(zip(self.possible_agents, ids))
        self._possible = set(self.possible_agents)
        self._seen: set[str] = set()
        self.sim: Sim | None = None
        self._steps = 0
        self._collisions = 0

    @functools.lru_cache(maxsize=None)
    def observation_space(self, agent: str) -> spaces.Box:
        return observation_space()

    @functools.lru_cache(maxsize=None)
    def action_space(self, agent: str) -> spaces.Box:
        return action_space()

    def _observe(self, agents: list[str] | None = None
                 ) -> tuple[dict[str, np.ndarray], float, set[str]]:
        """Observations of ``agents`` (the live ones without it) that are still present, the
        mean speed of every vehicle, and which are present."""
        agents = self.agents if agents is None else agents
        by_id, mean = self.task.observe(self.sim, [self._ids[a] for a in agents])
        obs = {f"vehicle_{i}": o for i, o in by_id.items()}
        return obs, mean, set(obs)

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None):
        sim_seed = int(np.random.default_rng(seed).integers(0, 2**31 - 1))
        self.sim = episode_sim(self.level, sim_seed, self.overrides, self.telemetry,
                               self.warmup_s)
        self._steps = 0
        self._collisions = self.sim.collisions
        self._seen = set()
        self.agents = self._arrivals()
        obs, _, _ = self._observe()
        infos = {a: {"seed": sim_seed} for a in self.agents}
        return obs, infos

    def _arrivals(self) -> list[str]:
        """The profile's vehicles present now that were never agents before, in id order."""
        v = self.sim.vehicles()
        mine = sorted(int(i) for i in v["id"][v["profile"] == self.profile])
        new = [f"vehicle_{i}" for i in mine]
        new = [a for a in new if a in self._possible and a not in self._seen]
        self._seen.update(new)
        return new

    def step(self, actions: dict[str, Any]):
        if self.sim is None:
            raise RuntimeError("call reset() before step()")
        accel = {agent: self.task.accel(actions.get(agent, [0.0])) for agent in self.agents}
        self.task.drive(self.sim, {self._ids[a]: x for a, x in accel.items()})
        self._steps += 1
        obs, mean, present = self._observe()
        collisions = self.sim.collisions
        new = collisions - self._collisions
        self._collisions = collisions
        out_of_time = self._steps * self.task.period_ticks * DT_S >= self.episode_s - 1e-9
        rewards, terms, truncs, infos = {}, {}, {}, {}
        for agent in self.agents:
            a = accel.get(agent, 0.0)
            rewards[agent] = self.task.reward(mean, a, new)
            terms[agent] = agent not in present
            truncs[agent] = out_of_time and agent in present
            infos[agent] = {"time_s": self.sim.time_s, "collisions": new}
        self.agents = [a for a in self.agents if not (terms[a] or truncs[a])]
        if not out_of_time:
            # Vehicles of the profile spawned during the step join.
            arrived = self._arrivals()
            if arrived:
                new_obs, _, _ = self._observe(arrived)
                obs.update(new_obs)
                for a in arrived:
                    # Every live agent has an entry: a newcomer has earned nothing yet.
                    rewards[a], terms[a], truncs[a] = 0.0, False, False
                    infos[a] = {"time_s": self.sim.time_s, "collisions": 0}
                self.agents += arrived
        return obs, rewards, terms, truncs, infos

    def render(self) -> np.ndarray | None:
        """With ``render_mode="rgb_array"``: the whole level now, top down, ``render_size``
        pixels; ``None`` without a render mode."""
        return whole_level_frame(self)


def most_spawned(level: Any, seconds: float) -> int:
    """How many vehicles ``level``'s spawners can spawn in ``seconds`` at most: each at its
    shortest interval (its own or a schedule step's), or its listed departures, capped by its
    ``max_vehicles``."""
    from .level import Level

    total = 0
    for sp in Level(level).to_dict().get("spawners", []):
        if sp.get("active", True) is False:
            continue
        shortest = min([sp["interval_s"]["min"]]
                       + [step["interval_s"]["min"] for step in sp.get("schedule", [])])
        n = len(sp.get("departures", [])) + int(np.ceil(seconds / max(shortest, 1e-3))) + 1
        cap = sp.get("max_vehicles")
        total += n if cap is None else min(n, int(cap))
    return total


def parallel_env(**kwargs: Any) -> LevelParallelEnv:
    """The PettingZoo ParallelEnv (keywords as :class:`LevelParallelEnv`)."""
    return LevelParallelEnv(**kwargs)


class SignalParallelEnv(ParallelEnv):
    """Every signalised junction of ``level`` is an agent (named after the junction), all
    choosing their next green phase at once every ``delta_time_s``: the PettingZoo twin of
    ``flockway/SignalControl-v0``, with the same keywords (``junctions`` limits the agents to
    those named). Each agent observes and is rewarded as that environment's agent; all are
    truncated together after ``episode_s``."""

    metadata = {"render_modes": ["rgb_array"], "name": "flockway_signal_parallel_v0",
                "render_fps": 2}
    render_size = (640, 480)

    def __init__(
        self,
        level: str = "signal_grid",
        junctions: list[str] | None = None,
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
        sim = Sim(level, overrides=self.overrides, csv=False)
        names = [s["junction"] for s in sim.signals()]
        if junctions is not None:
            unknown = [j for j in junctions if j not in names]
            if unknown:
                raise ValueError(f"{level}: no signalised junction {unknown[0]!r}; the "
                                 f"signalised junctions are: {', '.join(names) or 'none'}")
            names = [n for n in names if n in junctions]
        if not names:
            raise ValueError(f"{level}: the level has no signalised junction to control")
        self.possible_agents = list(names)
        self._spaces = {}
        for n in names:
            j = self.timing.junction(sim, n, reward)
            self._spaces[n] = (
                spaces.Box(0.0, 1.0, shape=(j.observation_size,), dtype=np.float32),
                spaces.Discrete(len(j.greens)),
            )
        self.agents: list[str] = []
        self.sim: Sim | None = None
        self.controlled: dict[str, Junction] = {}
        self._steps = 0

    def observation_space(self, agent: str) -> spaces.Box:
        return self._spaces[agent][0]

    def action_space(self, agent: str) -> spaces.Discrete:
        return self._spaces[agent][1]

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None):
        sim_seed = int(np.random.default_rng(seed).integers(0, 2**31 - 1))
        self.sim = episode_sim(self.level, sim_seed, self.overrides, self.telemetry,
                               self.timing.warmup_s)
        self.controlled = {
            n: self.timing.junction(self.sim, n, self.reward_spec) for n in self.possible_agents
        }
        if not self.fixed_time:
            for j in self.controlled.values():
                j.start(self.sim)
        self.agents = list(self.possible_agents)
        self._steps = 0
        lanes = self.sim.junctions()
        obs = {a: self.controlled[a].observe(self.sim, lanes) for a in self.agents}
        infos = {a: {"seed": sim_seed, **system_measures(lanes)} for a in self.agents}
        return obs, infos

    def step(self, actions: dict[str, Any]):
        if self.sim is None:
            raise RuntimeError("call reset() before step()")
        if not self.fixed_time:
            for a in self.agents:
                if a in actions:
                    self.controlled[a].act(self.sim, int(np.asarray(actions[a]).reshape(-1)[0]))
        self.sim.step(self.timing.delta_ticks)
        self._steps += 1
        lanes = self.sim.junctions()
        counts = lane_counts(self.sim) if self.reward_spec == "pressure" else None
        done = self.timing.done(self._steps)
        system = system_measures(lanes)
        obs, rewards, terms, truncs, infos = {}, {}, {}, {}, {}
        for a in self.agents:
            j = self.controlled[a]
            obs[a] = j.observe(self.sim, lanes)
            rewards[a] = j.reward(self.sim, lanes, counts)
            terms[a] = False
            truncs[a] = done
            infos[a] = {"time_s": self.sim.time_s, **system}
        if done:
            self.agents = []
        return obs, rewards, terms, truncs, infos

    def render(self) -> np.ndarray | None:
        """With ``render_mode="rgb_array"``: the whole level now, top down."""
        return whole_level_frame(self)


def signal_parallel_env(**kwargs: Any) -> SignalParallelEnv:
    """The PettingZoo ParallelEnv of signal control: an agent per signalised junction (keywords
    as :class:`SignalParallelEnv`)."""
    return SignalParallelEnv(**kwargs)
