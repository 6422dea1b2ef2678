"""Two builds of a criterion benchmark, run one after the other in turn, to judge a change on a
machine whose speed drifts: build the code before and after it, copy each benchmark binary
(``target/release/deps/NAME-HASH``, printed by ``cargo bench --bench NAME --no-run``) aside,
then

    python python/bench/alternate.py --bench 'ring_step/10000' --runs 4 before-scale after-scale

Prints each run's time per iteration (criterion's estimate and interval) as it comes and, at the
end, each binary's range and median of the estimates.
"""

from __future__ import annotations

import argparse
import re
import statistics
import subprocess
from pathlib import Path

UNITS = {"ps": 1e-6, "ns": 1e-3, "µs": 1.0, "us": 1.0, "ms": 1e3, "s": 1e6}
TIME = re.compile(r"time:\s+\[([\d.]+) (\S+) ([\d.]+) (\S+) ([\d.]+) (\S+)\]")


def estimate_us(output: str) -> tuple[float, float, float]:
    """Criterion's first ``time: [low estimate high]`` line, in µs."""
    m = TIME.search(output)
    if m is None:
        raise ValueError("no `time: [...]` line in the benchmark's output")
    values = [float(m.group(i)) * UNITS[m.group(i + 1)] for i in (1, 3, 5)]
    return values[0], values[1], values[2]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("binaries", type=Path, nargs="+", help="benchmark binaries to alternate")
    parser.add_argument("--bench", required=True, help="criterion filter, e.g. ring_step/10000")
    parser.add_argument("--runs", type=int, default=3, help="runs of each binary")
    parser.add_argument("--measurement-time", type=float, default=5.0,
                        help="criterion's measurement time per run, s")
    args = parser.parse_args()
    found: dict[Path, list[float]] = {b: [] for b in args.binaries}
    for run in range(args.runs):
        for binary in args.binaries:
            out = subprocess.run(
                [str(binary), "--bench", args.bench, "--measurement-time",
                 str(args.measurement_time), "--noplot", "--discard-baseline"],
                capture_output=True, text=True, check=True)
            low, mid, high = estimate_us(out.stdout)
            found[binary].append(mid)
            print(f"run {run + 1} {binary.name}: {mid:.1f} µs [{low:.1f} {high:.1f}]",
                  flush=True)
    for binary, mids in found.items():
        print(f"{binary.name}: {min(mids):.1f}–{max(mids):.1f} µs, median "
              f"{statistics.median(mids):.1f} ({len(mids)} runs)")


if __name__ == "__main__":
    main()
