//! Per-item work (its answers in the items' order) and per-car passes split over the task pool
//! or, on small levels, the join pool — so what a system does with them is the same whichever
//! thread found each.

use bevy_ecs::query::{
    ArchetypeFilter, ArchetypeQueryData, IterQueryData, QueryData, QueryFilter, QueryItem,
    QueryIter,
};
use bevy_ecs::system::Query;
use bevy_tasks::ComputeTaskPool;
use smallvec::SmallVec;
use std::sync::OnceLock;

/// The environment variable that sets from how many vehicles every per-car pass of the step
/// splits over the task pool, in place of each pass's own threshold. The results are the same
/// bytes for any value: tests set 1 to send every pass over the pool on a small level.
pub const PARALLEL_MIN_ENV: &str = "FLOCKWAY_PARALLEL_MIN";

/// The count [`PARALLEL_MIN_ENV`] asks for: `Ok(None)` when it is not set, an error that says
/// why when it is not a whole number from 1 up.
pub fn parallel_min_from_env() -> Result<Option<usize>, String> {
    crate::sim::count_from_env(
        PARALLEL_MIN_ENV,
        1..=usize::MAX,
        "a whole number of vehicles from 1 up",
    )
}

/// From how many items a pass whose own threshold is `default` splits over the task pool:
/// `default`, or what [`PARALLEL_MIN_ENV`] says (read once; the command line refuses a bad
/// value before anything runs, elsewhere it is ignored).
pub fn parallel_min(default: usize) -> usize {
    static FROM_ENV: OnceLock<Option<usize>> = OnceLock::new();
    FROM_ENV
        .get_or_init(|| parallel_min_from_env().ok().flatten())
        .unwrap_or(default)
}

/// How many threads the task pool has (1 before it is started).
pub fn pool_threads() -> usize {
    ComputeTaskPool::try_get().map_or(1, |pool| pool.thread_num())
}

/// How many threads a pass started on this thread splits over: the task pool's, or 1 while the
/// step stepping on this thread keeps its passes on one thread ([`SplitTuner`](crate::SplitTuner)).
pub fn task_threads() -> usize {
    if crate::split::split_allowed() {
        pool_threads()
    } else {
        1
    }
}

/// `f` over `items` (each call with the scratch space its thread made by `scratch`), the
/// answers in the items' order: over the task pool from `min_parallel` items on, split between
/// the threads of the join pool from [`JOIN_MIN_ITEMS`] below that (as
/// [`for_each_car`] does), in this thread below both or with one thread.
pub fn map_in_order<T, R, S>(
    items: &[T],
    min_parallel: usize,
    scratch: impl Fn() -> S + Sync,
    f: impl Fn(&mut S, &T) -> R + Sync,
) -> Vec<R>
where
    T: Sync,
    R: Send + 'static,
{
    let threads = task_threads();
    if items.len() < min_parallel.max(1) || threads < 2 {
        if threads >= 2 && items.len() >= parallel_min(JOIN_MIN_ITEMS.min(min_parallel)) {
            crate::split::note_split();
            return join_map(items, threads, &scratch, &f);
        }
        let mut s = scratch();
        return items.iter().map(|item| f(&mut s, item)).collect();
    }
    crate::split::note_split();
    let pool = ComputeTaskPool::get();
    // Two parts per thread, so a thread that finishes early takes another; each part is a task
    // handed over, which costs about as much as a few cars' work.
    let part = items.len().div_ceil(2 * threads);
    let (f, scratch) = (&f, &scratch);
    // The scope returns its tasks' answers in the order they were spawned.
    pool.scope(|scope| {
        for chunk in items.chunks(part) {
            scope.spawn(async move {
                let mut s = scratch();
                chunk.iter().map(|item| f(&mut s, item)).collect::<Vec<R>>()
            });
        }
    })
    .into_iter()
    .flatten()
    .collect()
}

/// From how many items a [`map_in_order`] below its task-pool threshold splits over the join
/// pool instead of running on one thread. Not tuned finely: below a few dozen items a light
/// item's share is about what a hand-over costs (the junction rule's decisions on `roundabout`
/// ran 1 % slower split from 32 items than from 64).
pub const JOIN_MIN_ITEMS: usize = 64;

/// From how many cars a pass [`for_each_car`] runs below its task-pool threshold splits over
/// the join pool. Each car's items are made on the thread that does its work, so a split pass
/// costs about 1 µs more than the same pass on one thread (four passes that did nothing added
/// 0.5 µs each to a `dense_road` step on one thread, 1.6 µs each on two): from a few dozen cars
/// the half of their work that moves saves more. `closed_loop` (50 cars) stepped 12 %
/// faster on two threads split from 32 cars than from 64 (`docs/performance.md`); a level of
/// about 16 cars split from 16 gained nothing.
pub const JOIN_MIN_CARS: usize = 32;

/// `f` on every item of `query`, each part of the items with its own scratch space from
/// `init`: over the task pool from `pool_min` items, split between the threads of the join pool
/// from [`JOIN_MIN_CARS`] (a pool that spins briefly between jobs, so a small pass does not wait
/// for a sleeping thread), on this thread below that or with one thread. Each call may touch only
/// its own item's mutable data, so the results do not depend on the split.
pub fn for_each_car<'a, 's, D, F, S>(
    query: &'a mut Query<'_, 's, D, F>,
    pool_min: usize,
    init: impl Fn() -> S + Send + Sync + Clone,
    f: impl Fn(&mut S, QueryItem<'a, 's, D>) + Send + Sync + Clone,
) where
    D: IterQueryData,
    F: ArchetypeFilter,
    <D as QueryData>::ReadOnly: ArchetypeQueryData,
    QueryItem<'a, 's, D>: Send,
{
    let threads = task_threads();
    let len = query.iter().len();
    if threads >= 2 && len >= parallel_min(pool_min) {
        crate::split::note_split();
        query.par_iter_mut().for_each_init(init, f);
    } else if threads >= 2 && len >= parallel_min(JOIN_MIN_CARS.min(pool_min)) {
        crate::split::note_split();
        // Each car's items are made on the thread that does its work: gathering them all here
        // and handing half over wrote some hundred bytes a car on this core for the other to
        // read back, each pass, and two threads took about a quarter longer on `dense_road`.
        join_walks(&mut walks_in_runs(query, threads), &init, &f);
    } else {
        let mut scratch = init();
        query.iter_mut().for_each(|item| f(&mut scratch, item));
    }
}

/// Work done beside the step, begun by [`beside`]: its answer is taken with [`Beside::join`].
pub struct Beside<T: Send + 'static>(BesideWork<T>);

/// Where the work of a [`Beside`] is.
enum BesideWork<T: Send + 'static> {
    /// Done already, on the thread that began it.
    Done(T),
    /// Handed to the join pool; the thread that joins it does it itself if no other has begun.
    Handed(micropool::OwnedTask<T>),
}

impl<T: Send + 'static> Beside<T> {
    /// The answer: waits for the thread doing the work to finish it, or does it here if no
    /// thread has begun it.
    pub fn join(self) -> T {
        match self.0 {
            BesideWork::Done(answer) => answer,
            BesideWork::Handed(task) => task.join(),
        }
    }
}

impl<T: Send + 'static> std::fmt::Debug for Beside<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self.0 {
            BesideWork::Done(_) => "Beside(done)",
            BesideWork::Handed(_) => "Beside(handed)",
        })
    }
}

/// `f` done beside the step: handed to the join pool's other thread while this one goes on with
/// the step's serial work, or done here and now with one thread (or while the step keeps its
/// passes on one thread). `f` owns what it reads, so its answer is the same either way.
pub fn beside<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> Beside<T> {
    if task_threads() >= 2 {
        crate::split::note_split();
        Beside(BesideWork::Handed(micropool::spawn_owned(f)))
    } else {
        Beside(BesideWork::Done(f()))
    }
}

/// One run of a query's items: the walk placed at the run's first item, and how many it holds.
struct Walk<'w, 's, D: QueryData, F: QueryFilter> {
    iter: QueryIter<'w, 's, D, F>,
    left: usize,
}

// SAFETY: a walk is not `Send` only because its fetches hold raw pointers into the world's
// component storage (bevy's own fetches: references, `Option`s, `Entity`, tuples of them; no
// query here has a fetch of its own making), storage that lives as long as `'w` whichever thread
// reads it (bevy's own parallel walk reads it from every thread of its pool). A walk (or the
// only mutable reference to it) moves to one thread and is used by that thread alone, and what it
// yields there is `Send` (the bound): the same as items made here and sent.
#[expect(
    unsafe_code,
    reason = "a run's walk moves to the thread that does it; bevy's own parallel walk needs the \
              task pool, whose hand-over costs more than a small level's pass"
)]
unsafe impl<'w, 's, D, F> Send for Walk<'w, 's, D, F>
where
    D: IterQueryData,
    F: QueryFilter,
    QueryItem<'w, 's, D>: Send,
{
}

/// The items of `query` in `parts` nearly equal runs, each a walk of its own placed at its run's
/// first item. Every walk is placed here, on this thread, before any is handed on: placing
/// one makes the items before its run and drops them, which may happen only while no item of
/// the query is alive anywhere.
fn walks_in_runs<'w, 's, D, F>(
    query: &'w mut Query<'_, 's, D, F>,
    parts: usize,
) -> Walks<'w, 's, D, F>
where
    D: IterQueryData,
    F: ArchetypeFilter,
    <D as QueryData>::ReadOnly: ArchetypeQueryData,
{
    // Borrowed exclusively for as long as the walks live, read through shared references.
    let query: &'w Query<'_, 's, D, F> = query;
    // `F` filters by archetype only, so this counts the whole walk.
    let len = query.iter().len();
    (0..parts)
        .map(|k| {
            let (start, end) = (len * k / parts, len * (k + 1) / parts);
            // SAFETY: every walk of the query meets the same cars in the same order (a walk is a
            // function of the query's matched tables and archetypes, and nothing can change the
            // world while `query` is borrowed exclusively); the runs are disjoint, so once they
            // start each car's items are made by one walk only, as `iter_mut` would make them
            // once. Placing this walk makes and drops the items before its run now, while no
            // walk has yielded anything.
            #[expect(
                unsafe_code,
                reason = "several walks of one query, each over a run of its own; bevy has no \
                          public walk over a part of a table"
            )]
            let mut iter = unsafe { query.iter_unsafe() };
            if start > 0 {
                iter.nth(start - 1);
            }
            Some(Walk {
                iter,
                left: end - start,
            })
        })
        .collect()
}

/// A pass's walks, one a thread: on the stack for as many threads as a small machine has (a
/// walk is some hundreds of bytes, and a heap block of that size a pass showed in the step).
/// Each is taken out of its slot by the thread that walks it, onto that thread's stack: walked
/// in place, side by side, each step of one walk wrote the cache line the other's was read from,
/// and two threads took an eighth longer.
type Walks<'w, 's, D, F> = SmallVec<[Option<Walk<'w, 's, D, F>>; 4]>;

/// `f` on every run's items, the runs split in halves joined on the join pool (the calling
/// thread does the later half itself, the pool's threads take the earlier).
fn join_walks<'w, 's, D, F, S>(
    walks: &mut [Option<Walk<'w, 's, D, F>>],
    init: &(impl Fn() -> S + Sync),
    f: &(impl Fn(&mut S, QueryItem<'w, 's, D>) + Sync),
) where
    D: IterQueryData,
    F: QueryFilter,
    QueryItem<'w, 's, D>: Send,
{
    if walks.len() < 2 {
        for walk in walks.iter_mut().filter_map(Option::take) {
            let mut scratch = init();
            walk.iter
                .take(walk.left)
                .for_each(|item| f(&mut scratch, item));
        }
        return;
    }
    let (earlier, later) = walks.split_at_mut(walks.len() / 2);
    micropool::join(
        || join_walks(earlier, init, f),
        || join_walks(later, init, f),
    );
}

/// `f` over `items` split into `parts` nearly equal runs, halves joined on the join pool; the
/// answers in the items' order.
fn join_map<T: Sync, R: Send, S>(
    items: &[T],
    parts: usize,
    scratch: &(impl Fn() -> S + Sync),
    f: &(impl Fn(&mut S, &T) -> R + Sync),
) -> Vec<R> {
    if parts < 2 || items.len() < 2 {
        let mut s = scratch();
        return items.iter().map(|item| f(&mut s, item)).collect();
    }
    let left_parts = parts / 2;
    let (left, right) = items.split_at(items.len() * left_parts / parts);
    let (mut answers, right) = micropool::join(
        || join_map(left, left_parts, scratch, f),
        || join_map(right, parts - left_parts, scratch, f),
    );
    answers.extend(right);
    answers
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    #[test]
    fn the_answers_come_in_the_items_order_with_one_thread_or_many() {
        crate::init_task_pool(Some(2));
        let items: Vec<u64> = (0..10_000).collect();
        // Each thread's scratch space counts its own calls; the answers do not depend on it.
        let square = |calls: &mut u64, x: &u64| {
            *calls += 1;
            x * x
        };
        let want: Vec<u64> = items.iter().map(|x| x * x).collect();
        assert_eq!(map_in_order(&items, 1, || 0u64, square), want);
        assert_eq!(map_in_order(&items, usize::MAX, || 0u64, square), want);
        assert_eq!(
            map_in_order(&items[..0], 1, || 0u64, square),
            Vec::<u64>::new()
        );
        assert_eq!(map_in_order(&items[..3], 1, || 0u64, square), want[..3]);
        // Below the task pool's threshold: one part below the join threshold, split from it.
        for n in [JOIN_MIN_ITEMS - 1, JOIN_MIN_ITEMS, 200] {
            let parts = AtomicUsize::new(0);
            let counted = || {
                parts.fetch_add(1, Ordering::Relaxed);
                0u64
            };
            assert_eq!(
                map_in_order(&items[..n], usize::MAX, counted, square),
                want[..n]
            );
            let parts = parts.load(Ordering::Relaxed);
            if n < JOIN_MIN_ITEMS {
                assert_eq!(parts, 1, "{n} items stay on one thread");
            } else if std::env::var_os(PARALLEL_MIN_ENV).is_none() {
                assert!(parts >= 2, "{n} items split into {parts} part(s)");
            }
        }
    }

    #[test]
    fn work_beside_the_step_gives_the_same_answer_on_either_thread() {
        crate::init_task_pool(Some(2));
        let sum = |n: u64| (0..n).map(|x| x * x).sum::<u64>();
        // Handed to the pool's other thread (or, if it has not begun, done at the join).
        let handed = beside(move || sum(100_000));
        assert_eq!(handed.join(), sum(100_000));
        // While the step keeps its passes on one thread, done where it was begun.
        crate::split::keep_one_thread_for_test(|| {
            let here = beside(move || sum(1_000));
            assert_eq!(format!("{here:?}"), "Beside(done)");
            assert_eq!(here.join(), sum(1_000));
        });
    }

    #[derive(bevy_ecs::component::Component)]
    struct Input(u64);

    #[derive(bevy_ecs::component::Component)]
    struct Output(u64);

    /// Puts some cars in a table of their own.
    #[derive(bevy_ecs::component::Component)]
    struct Marked;

    /// Puts some cars in archetypes of their own, their tables shared.
    #[derive(bevy_ecs::component::Component)]
    #[component(storage = "SparseSet")]
    struct Sparse;

    /// Spawns `n` cars with inputs 0..n and outputs 0, spread over several tables and
    /// archetypes, so a walk's runs cross from one to the next.
    fn spawn_cars(world: &mut bevy_ecs::world::World, n: u64) -> Vec<bevy_ecs::entity::Entity> {
        (0..n)
            .map(|i| {
                let mut car = world.spawn((Input(i), Output(0)));
                if i % 3 == 1 {
                    car.insert(Marked);
                }
                if i % 5 == 2 {
                    car.insert(Sparse);
                }
                car.id()
            })
            .collect()
    }

    /// Runs `for_each_car` over `n` cars with the task-pool threshold `pool_min`; returns each
    /// car's output in spawn order and how many parts the cars were split into.
    fn outputs(n: u64, pool_min: usize) -> (Vec<u64>, usize) {
        use bevy_ecs::system::RunSystemOnce;
        crate::init_task_pool(Some(2));
        let mut world = bevy_ecs::world::World::new();
        let cars = spawn_cars(&mut world, n);
        let parts = std::sync::Arc::new(AtomicUsize::new(0));
        let counted = parts.clone();
        world
            .run_system_once(move |mut q: Query<(&Input, &mut Output)>| {
                let counted = counted.clone();
                for_each_car(
                    &mut q,
                    pool_min,
                    move || {
                        counted.fetch_add(1, Ordering::Relaxed);
                        0u64
                    },
                    |calls: &mut u64, (input, mut output)| {
                        *calls += 1;
                        // Added to, so a car done twice would show.
                        output.0 += input.0 * input.0 + 1;
                    },
                );
            })
            .expect("the system runs");
        let got = cars
            .iter()
            .map(|&car| {
                world
                    .get::<Output>(car)
                    .expect("every car keeps its output")
                    .0
            })
            .collect();
        (got, parts.load(Ordering::Relaxed))
    }

    #[test]
    fn a_walk_in_any_number_of_parts_does_every_car_once() {
        use bevy_ecs::system::RunSystemOnce;
        crate::init_task_pool(Some(2));
        for parts in 1..=5 {
            for n in [0u64, 1, 2, 3, 7, 64, 129] {
                let mut world = bevy_ecs::world::World::new();
                let cars = spawn_cars(&mut world, n);
                world
                    .run_system_once(move |mut q: Query<(&Input, &mut Output)>| {
                        let run =
                            |(): &mut (), (input, mut output): QueryItem<(&Input, &mut Output)>| {
                                output.0 += input.0 + 1;
                            };
                        join_walks(&mut walks_in_runs(&mut q, parts), &|| (), &run);
                    })
                    .expect("the system runs");
                let got: Vec<u64> = cars
                    .iter()
                    .map(|&c| world.get::<Output>(c).map_or(0, |o| o.0))
                    .collect();
                let want: Vec<u64> = (0..n).map(|i| i + 1).collect();
                assert_eq!(got, want, "{n} cars in {parts} part(s)");
            }
        }
    }

    #[test]
    fn every_car_is_done_once_whether_split_joined_or_on_one_thread() {
        // Below the join threshold (one part), from it (split over the join pool) and over
        // the task pool: every car's output, none missed or done twice.
        for (n, pool_min) in [(10, usize::MAX), (200, usize::MAX), (2_000, 1)] {
            let (got, parts) = outputs(n, pool_min);
            let want: Vec<u64> = (0..n).map(|i| i * i + 1).collect();
            assert_eq!(got, want, "{n} cars, pool from {pool_min}");
            if n < JOIN_MIN_CARS as u64 {
                assert_eq!(parts, 1, "{n} cars stay on one thread");
            } else if std::env::var_os(PARALLEL_MIN_ENV).is_none() {
                assert!(parts >= 2, "{n} cars split into {parts} part(s)");
            }
        }
    }
}
