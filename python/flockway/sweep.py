"""Sweeps: levels × seeds × parameter overrides run as Ray tasks, on a local Ray by default or a
cluster, gathered into a pandas DataFrame of summaries."""

from __future__ import annotations

import itertools
import os
from typing import Any, Iterable, Mapping, Sequence

#: Summary keys left out of a sweep's rows: wall-clock figures, which differ from run to run.
WALL_CLOCK_KEYS = ("wall_seconds", "realtime_factor")


def grid_points(grid: Mapping[str, Sequence[float]] | Sequence[Mapping[str, float]] | None
                ) -> list[dict[str, float]]:
    """The override sets a grid stands for: every combination of a dict of value lists
    (``{"autonomous.gap_s": [10, 20], "human.reaction_time_s": [0.6, 0.8]}``: four), or a
    list of override dicts as given; one empty set without a grid."""
    if grid is None:
        return [{}]
    if isinstance(grid, Mapping):
        keys = list(grid)
        values = [list(grid[k]) for k in keys]
        return [dict(zip(keys, combo)) for combo in itertools.product(*values)]
    return [dict(g) for g in grid]


def summary_row(summary: Mapping[str, Any], overrides: Mapping[str, float]) -> dict[str, Any]:
    """One row of a sweep: the summary's own values (not the wall-clock ones), every metric by
    name (``speed_std_kmh.human``), the failed expectations and the overrides
    (``override.NAME``)."""
    row: dict[str, Any] = {}
    for k, v in summary.items():
        if k not in WALL_CLOCK_KEYS and not isinstance(v, (dict, list)):
            row[k] = v
    for name, value in sorted(summary.get("metrics", {}).items()):
        row.setdefault(name, value)
    failed = [e["name"] for e in summary.get("expectations", []) if not e["passed"]]
    row["failed_expectations"] = "; ".join(failed)
    for k, v in overrides.items():
        row[f"override.{k}"] = v
    return row


def run_one(level: str, seed: int, overrides: Mapping[str, float],
            seconds: float | None) -> dict[str, Any]:
    """One run of a sweep (what each Ray task does)."""
    from .sim import run

    return summary_row(run(level, seed=seed, overrides=overrides, seconds=seconds), overrides)


def sweep(
    levels: Iterable[str | os.PathLike[str]],
    seeds: Iterable[int],
    grid: Mapping[str, Sequence[float]] | Sequence[Mapping[str, float]] | None = None,
    address: str | None = None,
    seconds: float | None = None,
    num_cpus: int | None = None,
):
    """Runs every level × override set × seed as a Ray task and returns a pandas DataFrame, a
    row per run in that order: ``level``, ``seed``, ``passed``, the summary's keys, every metric
    by name (``speed_std_kmh.human``), ``failed_expectations`` and the overrides
    (``override.NAME``). The numbers are the ones ``flockway test`` measures for the same runs.

    ``address`` connects to a Ray cluster (``"ray://head:10001"`` or ``"auto"``); without it a
    local Ray is started (with ``num_cpus`` workers) unless one is running. A level file must be
    readable at the same path on every node, or name a shipped level."""
    import pandas as pd
    import ray

    from .data import level_path

    paths = [str(level_path(level)) for level in levels]
    seeds = [int(s) for s in seeds]
    points = grid_points(grid)
    if not ray.is_initialized():
        ray.init(
            address=address,
            num_cpus=None if address else num_cpus,
            include_dashboard=False,
            log_to_driver=False,
            configure_logging=False,
        )
    task = ray.remote(run_one)
    futures = [
        task.remote(path, seed, point, seconds)
        for path in paths
        for point in points
        for seed in seeds
    ]
    return pd.DataFrame(ray.get(futures))
