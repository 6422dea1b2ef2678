"""Where each thread's time goes: a ``perf`` profile with call stacks, each sample put under the
outermost Flockway system on its stack, and counted as parallel work when a task-pool or join-pool
frame is on it (the main thread's serial share is what bounds a step's speed-up on more cores).
The scale benchmark's binary and `flockway run` of a shipped level are read alike.

    perf record -o perf.data --call-graph dwarf,65528 -F 97 \\
        target/release/deps/scale-HASH --bench 'ring_step/10000' --measurement-time 5 --noplot
    perf script -i perf.data -F tid,ip,sym > perf.txt
    python python/bench/thread_profile.py perf.txt

Copy the whole stack size perf allows (65528 bytes): the main thread's stacks are deep, and
cut short they end before the frames that tell parallel work from serial. The main thread is
the one with the lowest thread id (the process's first); every thread's samples are listed,
largest first, down to ``--min-share`` per cent.
"""

from __future__ import annotations

import argparse
import re
from collections import Counter
from collections.abc import Iterable, Iterator
from pathlib import Path

# Frames that mark a sample as work handed out over the task pool, or over the join pool that
# splits the passes of a level too small for the task pool (`flockway run` of a shipped level).
PARALLEL_MARKS = ("async_task", "execute_global_scope", "par_fold", "TaskPool>::scope",
                  "micropool::", "flockway_core::parallel::join_walks",
                  "flockway_core::parallel::join_map")
# Flockway frames that are the step's machinery rather than a system: the step itself, the
# passes' splitting, and the command line and runner around a `flockway run`.
MACHINERY = ("flockway_core::sim", "flockway_core::parallel", "flockway_runner::", "flockway::")
# An inlined frame of a plain function: a system inlined into bevy's call of it.
INLINED = re.compile(r"^([a-z_][a-z0-9_]*)(<.*>)? \(inlined\)$")


def samples(lines: Iterable[str]) -> Iterator[tuple[int, list[str]]]:
    """Each sample of ``perf script -F tid,ip,sym`` output: its thread id and its frames' symbols,
    innermost first."""
    tid: int | None = None
    frames: list[str] = []
    for line in lines:
        line = line.rstrip("\n")
        if not line.strip():
            if tid is not None and frames:
                yield tid, frames
            tid, frames = None, []
        elif line.startswith("\t"):
            parts = line.strip().split(" ", 1)
            frames.append(parts[1] if len(parts) > 1 else "")
        else:
            tid = int(line.split()[0].split("/")[-1])
    if tid is not None and frames:
        yield tid, frames


# What a sample whose stack perf could not unwind to its start is put under.
CUT_SHORT = "(stack cut short: record with --call-graph dwarf,65528)"


def system_of(frames: list[str]) -> str:
    """The outermost Flockway system on a stack (``rapier step`` for rapier's own, ``other`` for
    neither, ``CUT_SHORT`` when the stack ends before its thread's start)."""
    if frames and frames[-1] == "[unknown]":
        return CUT_SHORT
    # In a release build a system's function is inlined into bevy's call of it: the first
    # plainly named inlined frame inside `call_inner` (past its `call_mut`s) is the system.
    in_call = False
    for frame in reversed(frames):
        if frame.startswith("flockway_") and not frame.startswith(MACHINERY):
            return re.sub(r"[<{(].*", "", frame)
        if frame.startswith("rapier3d::pipeline::physics_world"):
            return "rapier step"
        if frame.startswith("call_inner<"):
            in_call = True
        elif in_call and not frame.startswith("call_mut<"):
            inlined = INLINED.match(frame)
            if inlined:
                return inlined.group(1)
            in_call = False
    return "other"


def is_parallel(frames: list[str]) -> bool:
    """Whether a sample is in work handed out over the task pool."""
    return any(mark in frame for frame in frames for mark in PARALLEL_MARKS)


def attribute(
        stacks: Iterable[tuple[int, list[str]]]) -> dict[int, Counter[tuple[str, bool]]]:
    """Per thread, the samples under each (system, parallel) pair."""
    out: dict[int, Counter[tuple[str, bool]]] = {}
    for tid, frames in stacks:
        out.setdefault(tid, Counter())[(system_of(frames), is_parallel(frames))] += 1
    return out


def report(by_thread: dict[int, Counter[tuple[str, bool]]], min_share: float) -> str:
    """The threads' shares as text, the main thread first."""
    lines = []
    for n, tid in enumerate(sorted(by_thread)):
        counts = by_thread[tid]
        total = sum(counts.values())
        serial = sum(v for (_, par), v in counts.items() if not par)
        role = "main thread" if n == 0 else "thread"
        lines.append(f"{role} {tid}: {total} samples, {100 * serial / total:.1f} % outside "
                     "parallel work")
        for (name, par), v in counts.most_common():
            share = 100 * v / total
            if share >= min_share:
                lines.append(f"  {share:5.1f} %  {'parallel' if par else 'serial  '}  {name}")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("script", type=Path, help="output of `perf script -F tid,ip,sym`")
    parser.add_argument("--min-share", type=float, default=0.8,
                        help="list a system only from this share of its thread's samples, %%")
    args = parser.parse_args()
    with args.script.open(encoding="utf-8", errors="replace") as f:
        print(report(attribute(samples(f)), args.min_share))


if __name__ == "__main__":
    main()
