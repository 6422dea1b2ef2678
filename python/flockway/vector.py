"""Many environments stepped together in one process: :class:`VectorEnv` steps N gymnasium
environments over a pool of threads. ``Sim.step`` lets go of Python's global interpreter lock
while the simulation runs, so the environments' simulations run on all cores at once, with no
subprocesses to start and no observations to pickle."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from typing import Any, Callable, Sequence

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space, concatenate, create_empty_array, iterate


class VectorEnv(gym.vector.VectorEnv):
    """``num_envs`` copies of environment ``env_id`` (made by ``gym.make(env_id, **kwargs)``),
    or the environments ``env_fns`` make, stepped in parallel on ``threads`` threads (one per
    environment without it).

    It is a ``gymnasium.vector.VectorEnv`` with the next-step autoreset of gymnasium's own
    vector environments: the step after an episode ends resets that environment and returns its
    first observation (reward 0, not done). ``reset(seed=s)`` seeds environment ``i`` with
    ``s + i``. Each environment is its own simulation, so stepping them together gives exactly
    what stepping each alone gives; set ``FLOCKWAY_THREADS=1`` (or ``flockway.set_threads(1)``)
    so that the environments, not one simulation's task pool, share the cores.
    """

    def __init__(
        self,
        env_id: str | None = None,
        num_envs: int | None = None,
        *,
        env_fns: Sequence[Callable[[], gym.Env]] | None = None,
        threads: int | None = None,
        **kwargs: Any,
    ) -> None:
        if (env_id is None) == (env_fns is None):
            raise ValueError("give env_id (with num_envs) or env_fns, not both")
        if env_fns is None:
            if num_envs is None or int(num_envs) < 1:
                raise ValueError(f"num_envs={num_envs!r}: expected 1 or more")
            env_fns = [lambda: gym.make(env_id, **kwargs) for _ in range(int(num_envs))]
        self.envs = [fn() for fn in env_fns]
        if not self.envs:
            raise ValueError("env_fns is empty: expected 1 or more environments")
        self.num_envs = len(self.envs)
        if threads is not None and int(threads) < 1:
            raise ValueError(f"threads={threads!r}: expected 1 or more")
        self._pool = ThreadPoolExecutor(max_workers=int(threads or self.num_envs))
        first = self.envs[0]
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.metadata = dict(first.metadata)
        self.metadata["autoreset_mode"] = AutoresetMode.NEXT_STEP
        self.render_mode = first.render_mode
        self.spec = first.spec
        self._autoreset = np.zeros(self.num_envs, dtype=np.bool_)

    def _batch(self, observations: list[Any]) -> Any:
        out = create_empty_array(self.single_observation_space, n=self.num_envs, fn=np.zeros)
        return concatenate(self.single_observation_space, observations, out)

    def reset(self, *, seed: int | Sequence[int | None] | None = None,
              options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        if seed is None or isinstance(seed, (int, np.integer)):
            seeds = [None if seed is None else int(seed) + i for i in range(self.num_envs)]
        else:
            seeds = list(seed)
            if len(seeds) != self.num_envs:
                raise ValueError(f"{len(seeds)} seeds for {self.num_envs} environments")
        results = list(self._pool.map(
            lambda i: self.envs[i].reset(seed=seeds[i], options=options), range(self.num_envs)))
        self._autoreset[:] = False
        infos: dict[str, Any] = {}
        for i, (_, info) in enumerate(results):
            infos = self._add_info(infos, info, i)
        return self._batch([obs for obs, _ in results]), infos

    def step(self, actions: Any) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        each = list(iterate(self.action_space, actions))

        def one(i: int) -> tuple[Any, float, bool, bool, dict[str, Any]]:
            if self._autoreset[i]:
                obs, info = self.envs[i].reset()
                return obs, 0.0, False, False, info
            return self.envs[i].step(each[i])

        results = list(self._pool.map(one, range(self.num_envs)))
        rewards = np.array([r[1] for r in results], dtype=np.float64)
        terminations = np.array([r[2] for r in results], dtype=np.bool_)
        truncations = np.array([r[3] for r in results], dtype=np.bool_)
        infos: dict[str, Any] = {}
        for i, r in enumerate(results):
            infos = self._add_info(infos, r[4], i)
        self._autoreset = terminations | truncations
        return self._batch([r[0] for r in results]), rewards, terminations, truncations, infos

    def render(self) -> tuple[Any, ...] | None:
        """Each environment's frame."""
        return tuple(env.render() for env in self.envs)

    def close_extras(self, **kwargs: Any) -> None:
        self._pool.shutdown(wait=True)
        for env in self.envs:
            env.close()
