"""The profiling helpers of ``python/bench``: a thread profile attributes samples as the
performance page says, the alternating runner reads criterion's estimate in any unit, and the
SUMO comparison reckons SUMO's figures with the step it ran."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import pytest

BENCH = Path(__file__).resolve().parents[2] / "python" / "bench"


def load(name: str) -> ModuleType:
    spec = importlib.util.spec_from_file_location(name, BENCH / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


# Four samples as `perf script -F tid,ip,sym` prints them: the main thread (100) in a parallel
# pass it took part in, in a serial system, and in rapier; a pool thread (104) in a parallel pass.
PERF = """\
     100 
\t          1a2b flockway_vehicle::forces::vehicle_forces
\t          1a2c async_task::raw::RawTask<F,T,S,M>::run
\t          1a2d flockway_vehicle::systems::drive_vehicles
\t          1a2e flockway_core::sim::Sim::step

     100 
\t          2a2b core::slice::sort::unstable::quicksort::quicksort
\t          2a2c flockway_drivers::perception::rebuild_lane_index
\t          2a2d flockway_core::sim::Sim::step

     100 
\t          3a2b rapier3d::dynamics::solver::solve
\t          3a2c rapier3d::pipeline::physics_world::PhysicsWorld::step
\t          3a2d flockway_vehicle::physics::step_physics
\t          3a2e flockway_core::sim::Sim::step

     104 
\t          4a2b flockway_drivers::models::flock_law
\t          4a2c flockway_drivers::pipeline::decide_one<flockway_drivers::models::FlockDriver>
\t          4a2d bevy_ecs::query::state::QueryState<D,F>::par_fold_init_unchecked_manual
"""


def test_samples_go_under_the_outermost_system_and_the_pool_marks_parallel_work() -> None:
    tp = load("thread_profile")
    by_thread = tp.attribute(tp.samples(PERF.splitlines(keepends=True)))
    assert set(by_thread) == {100, 104}
    main = by_thread[100]
    assert main[("flockway_vehicle::systems::drive_vehicles", True)] == 1
    assert main[("flockway_drivers::perception::rebuild_lane_index", False)] == 1
    # The outermost Flockway system wins over rapier's frames beneath it.
    assert main[("flockway_vehicle::physics::step_physics", False)] == 1
    assert by_thread[104] == {("flockway_drivers::pipeline::decide_one", True): 1}
    text = tp.report(by_thread, min_share=0.0)
    assert text.splitlines()[0] == "main thread 100: 3 samples, 66.7 % outside parallel work"
    assert "thread 104: 1 samples, 0.0 % outside parallel work" in text


# Three samples of `flockway run`'s main thread (200): a pass split over the join pool, a system
# inlined into bevy's call of it, and a pass on one thread; one of the join pool's thread (201).
RUN = """\
     200 
\t          1a2b flockway_vehicle::systems::drive_one
\t          1a2c flockway_core::parallel::join_walks
\t          1a2d micropool::thread_pool::ThreadPool::join
\t          1a2e flockway_vehicle::systems::drive_vehicles
\t          1a2f flockway_runner::runner::Runner::step
\t          1a30 flockway::main

     200 
\t          2a2b alloc::vec::Vec<T>::push
\t          2a2c run_destroyers (inlined)
\t          2a2d call_mut<fn(bevy_ecs::change_detection::params::Res<Clock>)> (inlined)
\t          2a2e call_inner<(), bevy_ecs::change_detection::params::Res<Clock>> (inlined)
\t          2a2f <bevy_ecs::system::function_system::FunctionSystem<M,I,O,F>>::run_unsafe
\t          2a30 flockway_runner::runner::Runner::step
\t          2a31 flockway::main

     200 
\t          3a2b flockway_vehicle::systems::drive_one
\t          3a2c flockway_core::parallel::for_each_car
\t          3a2d flockway_vehicle::systems::drive_vehicles
\t          3a2e flockway_runner::runner::Runner::step

     201 
\t          4a2b core::hint::spin_loop
\t          4a2c micropool::thread_pool::ThreadPool::join
"""


def test_a_run_s_join_pool_is_parallel_and_its_inlined_systems_are_named() -> None:
    tp = load("thread_profile")
    by_thread = tp.attribute(tp.samples(RUN.splitlines(keepends=True)))
    # The runner and the command line are machinery: each sample goes under its system.
    assert by_thread[200] == {
        ("flockway_vehicle::systems::drive_vehicles", True): 1,
        ("run_destroyers", False): 1,
        ("flockway_vehicle::systems::drive_vehicles", False): 1,
    }
    assert by_thread[201] == {("other", True): 1}


def test_a_stack_perf_could_not_unwind_is_put_under_its_own_name() -> None:
    tp = load("thread_profile")
    cut = "100 \n\t  5a2b flockway_vehicle::systems::drive_vehicles\n\t  0 [unknown]\n\n"
    by_thread = tp.attribute(tp.samples(cut.splitlines(keepends=True)))
    assert by_thread[100] == {(tp.CUT_SHORT, False): 1}
    assert "dwarf,65528" in tp.report(by_thread, min_share=0.0)


@pytest.mark.parametrize(("line", "micros"), [
    ("scale/ring_step/10000   time:   [8.3318 ms 8.6066 ms 8.9618 ms]", 8606.6),
    ("dense   time:   [412.05 µs 414.20 µs 418.00 µs]", 414.2),
    ("step    time:   [1.6412 ns 1.7000 ns 1.7512 ns]", 0.0017),
])
def test_the_alternating_runner_reads_criterion_s_estimate_in_microseconds(
        line: str, micros: float) -> None:
    low, mid, high = load("alternate").estimate_us(f"Benchmarking...\n{line}\n")
    assert low < mid < high
    assert mid == pytest.approx(micros)


def test_the_alternating_runner_says_when_there_is_no_estimate() -> None:
    with pytest.raises(ValueError, match="no `time"):
        load("alternate").estimate_us("error: no benchmark matched\n")


def test_sumo_s_vehicle_seconds_are_reckoned_with_the_step_it_ran(tmp_path: Path) -> None:
    # Asked for 1/120 s, SUMO (whole milliseconds) steps every 8 ms: four steps of 8 ms with
    # 2, 3, 3 and 4 vehicles running are 12 vehicle-steps and 0.096 vehicle-seconds.
    summary = tmp_path / "summary.xml"
    summary.write_text(
        "<summary>\n"
        + "".join(f'  <step time="{t:.3f}" running="{n}"/>\n'
                  for t, n in ((0.0, 2), (0.008, 3), (0.016, 3), (0.024, 4)))
        + "</summary>\n")
    seconds, steps = load("sumo_compare").summary_totals(summary, 1.0 / 120.0)
    assert steps == 12
    assert seconds == pytest.approx(12 * 0.008)
    # A summary of one step falls back to the step asked for.
    summary.write_text('<summary><step time="0.00" running="5"/></summary>\n')
    assert load("sumo_compare").summary_totals(summary, 0.1) == (pytest.approx(0.5), 5)
