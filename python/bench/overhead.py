"""What stepping from Python costs: ``dense_road`` stepped from Python against ``flockway run``,
and a thousand cars driven by a Python driver against the clock.

    python python/bench/overhead.py [--repeat 3] [--flockway target/release/flockway]

Each figure is the median of ``--repeat`` runs, measured back to back on the same machine; the
stepping time of ``flockway run`` is its summary's ``wall_seconds`` (stepping only, as Python's
is timed around the steps only).
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

import flockway

ROOT = Path(__file__).resolve().parents[2]


def cli_seconds(exe: Path, level: Path) -> float:
    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "s.json"
        subprocess.run([str(exe), "run", str(level), "--summary", str(out)], check=True,
                       capture_output=True)
        return json.loads(out.read_text())["wall_seconds"]


def python_seconds(level: Path, chunk: int | None, observe: bool) -> float:
    sim = flockway.Sim(level)
    ticks = round(sim.duration_s * 120)
    start = time.perf_counter()
    if chunk is None:
        sim.step(ticks)
    else:
        for _ in range(ticks // chunk):
            sim.step(chunk)
            if observe:
                sim.vehicles()
    return time.perf_counter() - start


class GapKeeper:
    def decide(self, obs):
        v = obs["speed_mps"]
        lead = np.where(np.isfinite(obs["leader_speed_mps"]), obs["leader_speed_mps"], 25.0)
        return np.clip(lead + (obs["gap_m"] - 2.0 - 1.5 * v) / 2.0, 0.0, 25.0)


def thousand_car_level(dir: Path) -> Path:
    """A four-lane 3 km ring with 250 custom-model cars per lane (a car every 12 m)."""
    import math

    n = 64
    radius = 3000.0 / (2 * math.pi)
    points = ", ".join(
        f"(pos: ({radius * math.cos(2 * math.pi * k / n):.3f}, "
        f"{radius * math.sin(2 * math.pi * k / n):.3f}, 0.0))"
        for k in range(n)
    )
    groups = ", ".join(
        f'(road: "ring", lane: {lane}, count: 250, profile: "mine", from_m: 0.0, '
        f"to_m: 2990.0, speed_kmh: 60.0)"
        for lane in range(4)
    )
    text = f"""(
    version: 1,
    name: "thousand",
    seed: 1,
    duration_s: 30.0,
    roads: [(name: "ring", closed: true, lanes: 4, speed_limit_kmh: 90.0, points: [{points}])],
    vehicle_types: [(name: "sedan", path: "vehicles/sedan.ron")],
    driver_profiles: [(name: "mine", model: Custom("keeper"), vehicle: "sedan")],
    vehicles: [{groups}],
)
"""
    import shutil

    shutil.copytree(flockway.data_dir() / "assets", dir / "assets", dirs_exist_ok=True)
    path = dir / "thousand.ron"
    path.write_text(text)
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--flockway", type=Path, default=ROOT / "target/release/flockway")
    args = parser.parse_args()
    dense = ROOT / "levels" / "dense_road.ron"
    med = lambda f: statistics.median(f() for _ in range(args.repeat))  # noqa: E731
    cli = med(lambda: cli_seconds(args.flockway, dense))
    one_call = med(lambda: python_seconds(dense, None, False))
    per_step = med(lambda: python_seconds(dense, 1, False))
    per_step_observed = med(lambda: python_seconds(dense, 1, True))
    print(f"dense_road, 120 s simulated (median of {args.repeat}):")
    print(f"  flockway run                         {cli:7.2f} s stepping")
    for name, t in (
        ("Sim.step(14400), one call", one_call),
        ("Sim.step(1) x 14400", per_step),
        ("Sim.step(1) + vehicles() x 14400", per_step_observed),
    ):
        print(f"  {name:36} {t:7.2f} s  ({100 * (t / cli - 1):+.1f} %)")
    with tempfile.TemporaryDirectory() as d:
        level = thousand_car_level(Path(d))

        def driven() -> float:
            sim = flockway.Sim(level, drivers={"keeper": GapKeeper()})
            sim.step(1)
            assert len(sim.vehicles()["id"]) == 1000
            start = time.perf_counter()
            sim.step(120 * 10)
            return time.perf_counter() - start

        t = med(driven)
    print(f"1000 cars driven by a Python driver every step, 10 s simulated: {t:.2f} s "
          f"({10.0 / t:.2f}x real time)")


if __name__ == "__main__":
    main()
