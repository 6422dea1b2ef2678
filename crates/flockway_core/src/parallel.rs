//! Per-item work split over the task pool with its answers in the items' order, so what a
//! system does with them is the same whichever thread found each.

use bevy_tasks::ComputeTaskPool;
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
pub fn task_threads() -> usize {
    ComputeTaskPool::try_get().map_or(1, |pool| pool.thread_num())
}

/// `f` over `items` (each call with the scratch space its thread made by `scratch`), the
/// answers in the items' order: over the task pool from `min_parallel` items on, in this
/// thread below that (where handing the work out would cost more than it saves).
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
        let mut s = scratch();
        return items.iter().map(|item| f(&mut s, item)).collect();
    }
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

#[cfg(test)]
mod tests {
    use super::*;

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
    }
}
