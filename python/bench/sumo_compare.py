"""Flockway against SUMO on the same scenario, one after the other: ``levels/dense_road.ron``
(a 4-lane road, 200 m straight, a 90° left curve of radius 150 m, 300 m straight, one car per
lane every 0.9–1.1 s at 60 km/h for 120 s) and the same road and demand in SUMO (its
netconvert builds the road from the same shape; a flow per lane, one car a second, Krauss cars
4.6 m long keeping 0.5 s, so that SUMO can insert them all), SUMO at steps of 1/120 s
(Flockway's), 0.1 s and 1 s. Each run's figures are the simulated vehicle-seconds per wall second (the vehicles on the road
summed over the steps, times the step, over the wall time of the run) and the vehicle-steps per
wall second (the same sum over the wall time); SUMO's from its summary output, its wall time the
whole process; Flockway's stepping time and vehicle-steps as ``flockway run`` prints them.
SUMO keeps time in whole milliseconds, so asked for 1/120 s it steps every 8 ms (15 000 steps in
120 s): its vehicle-seconds are reckoned with the step it ran, read off its summary's times.
``--action-step S`` (repeatable) adds Flockway with its drivers deciding every ``S`` seconds
(``flockway run --action-step``) beside it.

    python python/bench/sumo_compare.py --flockway target/release/flockway --repeat 3

``sumo`` and ``netconvert`` come from PATH or ``FLOCKWAY_SUMO_BIN`` (``pip install
eclipse-sumo`` installs both).
"""

from __future__ import annotations

import argparse
import math
import os
import re
import shutil
import subprocess
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
STEPS_S = (1.0 / 120.0, 0.1, 1.0)


def tool(name: str) -> str:
    where = os.environ.get("FLOCKWAY_SUMO_BIN")
    found = shutil.which(name, path=where) if where else None
    found = found or shutil.which(name)
    if not found:
        raise SystemExit(f"`{name}` not found: pip install eclipse-sumo, or set FLOCKWAY_SUMO_BIN")
    return found


def dense_road_shape() -> list[tuple[float, float]]:
    """The centre line of dense_road: 200 m along x, a quarter circle of radius 150 m to the
    left, 300 m along y."""
    pts = [(0.0, 0.0), (200.0, 0.0)]
    for k in range(1, 16):
        a = math.pi / 2 * k / 16
        pts.append((200.0 + 150.0 * math.sin(a), 150.0 - 150.0 * math.cos(a)))
    pts += [(350.0, 150.0), (350.0, 450.0)]
    return pts


def write_scenario(d: Path) -> tuple[Path, Path]:
    shape = " ".join(f"{x:.3f},{y:.3f}" for x, y in dense_road_shape())
    (d / "r.nod.xml").write_text(
        '<nodes><node id="a" x="0" y="0"/><node id="b" x="350" y="450"/></nodes>\n')
    (d / "r.edg.xml").write_text(
        f'<edges><edge id="main" from="a" to="b" numLanes="4" speed="16.667" '
        f'width="3.0" shape="{shape}"/></edges>\n')
    net = d / "r.net.xml"
    subprocess.run([tool("netconvert"), "-n", str(d / "r.nod.xml"), "-e", str(d / "r.edg.xml"),
                    "-o", str(net), "--no-warnings"], check=True, capture_output=True)
    flows = "".join(
        f'<flow id="f{i}" type="car" route="r" begin="0" end="120" period="1" '
        f'departLane="{i}" departSpeed="16.667" departPos="5" arrivalPos="720"/>'
        for i in range(4))
    rou = d / "r.rou.xml"
    rou.write_text(
        # A time gap of 0.5 s and 1 m standstill gap: with SUMO's defaults (1 s, 2.5 m) it
        # cannot insert a car a second per lane at 60 km/h, and the road would carry less.
        '<routes><vType id="car" length="4.6" minGap="1.0" tau="0.5" maxSpeed="16.667" '
        'accel="2.6" decel="4.5" sigma="0.5"/><route id="r" edges="main"/>' + flows
        + "</routes>\n")
    return net, rou


def sumo_run(net: Path, rou: Path, step_s: float, d: Path) -> tuple[float, float, int]:
    """Wall seconds, simulated vehicle-seconds and vehicle-steps, each reckoned with the step SUMO
    ran (its time is whole milliseconds: 1/120 s runs as 8 ms)."""
    summary = d / f"summary_{step_s:.6f}.xml"
    started = time.perf_counter()
    subprocess.run([tool("sumo"), "-n", str(net), "-r", str(rou), "--step-length",
                    repr(step_s), "--end", "120", "--summary-output", str(summary),
                    "--no-step-log", "--no-warnings", "--duration-log.disable"],
                   check=True, capture_output=True)
    wall = time.perf_counter() - started
    vehicle_seconds, vehicle_steps = summary_totals(summary, step_s)
    return wall, vehicle_seconds, vehicle_steps


def summary_totals(summary: Path, step_s: float) -> tuple[float, int]:
    """Simulated vehicle-seconds and vehicle-steps of a SUMO summary output: the vehicles running
    summed over its steps, times the step it ran (read off the steps' times; `step_s`, the step
    asked for, when it holds one step only)."""
    steps = list(ET.parse(summary).getroot().iter("step"))
    running = [int(s.get("running")) for s in steps]
    times = [float(s.get("time")) for s in steps]
    ran_s = (times[-1] - times[0]) / (len(times) - 1) if len(times) > 1 else step_s
    return sum(running) * ran_s, sum(running)


def flockway_run(binary: str, action_step_s: float = 0.0) -> tuple[float, float, int]:
    """Stepping wall seconds, simulated vehicle-seconds and vehicle-steps of `flockway run
    dense_road`, its drivers deciding every `action_step_s` (0: every tick)."""
    out = subprocess.run([binary, "run", str(ROOT / "levels" / "dense_road.ron"),
                          "--action-step", repr(action_step_s)],
                         capture_output=True, text=True)
    # Exit 1 is a failed expectation (deciding every 0.1 s, fewer cars get on than the level
    # expects): the run itself is whole. Anything else is an error.
    if out.returncode not in (0, 1):
        raise subprocess.CalledProcessError(out.returncode, out.args, out.stdout, out.stderr)
    out = out.stdout
    wall = float(re.search(r"wall\s+([\d.]+) s", out).group(1))
    vehicle_steps = int(re.search(r"vehicle-steps\s+(\d+)", out).group(1))
    return wall, vehicle_steps / 120.0, vehicle_steps


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--flockway", default=str(ROOT / "target" / "release" / "flockway"))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--action-step", type=float, action="append", default=[], metavar="S",
                    help="also run Flockway with its drivers deciding every S s (repeatable)")
    args = ap.parse_args()
    version = subprocess.run([tool("sumo"), "--version"], capture_output=True,
                             text=True).stdout.splitlines()[0]
    print(f"{version}; {os.cpu_count()} cores; {args.repeat} runs each, alternated")
    # Per row: (vehicle-seconds, vehicle-steps) per wall second, each run.
    rows: dict[str, list[tuple[float, float]]] = {}
    mean: dict[str, float] = {}
    flockway, sumo_same = "Flockway, 1/120 s (rigid bodies, tyres)", "SUMO, 1/120 s (Krauss)"
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        net, rou = write_scenario(d)
        for _ in range(args.repeat):
            for action_step in [0.0, *args.action_step]:
                wall, vs, steps = flockway_run(args.flockway, action_step)
                name = flockway
                if action_step > 0.0:
                    name += f", deciding every {action_step:g} s"
                rows.setdefault(name, []).append((vs / wall, steps / wall))
                mean[name] = vs / 120.0
            for step in STEPS_S:
                wall, vs, steps = sumo_run(net, rou, step, d)
                name = f"SUMO, {'1/120' if step < 0.01 else f'{step:g}'} s (Krauss)"
                rows.setdefault(name, []).append((vs / wall, steps / wall))
                mean[name] = vs / 120.0
    print("| simulator, step | vehicles on the road (mean) | vehicle-seconds per wall second "
          "(each run) | vehicle-steps per wall second (each run) |")
    print("|---|---|---|---|")
    for name, rates in rows.items():
        seconds = " / ".join(f"{r[0]:,.0f}" for r in rates)
        steps = " / ".join(f"{r[1]:,.0f}" for r in rates)
        print(f"| {name} | {mean[name]:.0f} | {seconds} | {steps} |")
    # Flockway over SUMO at (nearly) the same step, run for run: SUMO's 8 ms against 1/120 s.
    pairs = list(zip(rows[flockway], rows[sumo_same]))
    for k, what in ((0, "vehicle-seconds"), (1, "vehicle-steps")):
        ratios = " / ".join(f"{f[k] / s[k]:.2f}" for f, s in pairs)
        print(f"Flockway / SUMO at the same step, {what} per wall second: {ratios}")


if __name__ == "__main__":
    main()
