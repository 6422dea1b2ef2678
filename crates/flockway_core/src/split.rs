//! Whether a step's per-car passes split over the threads, decided by timing the step both ways
//! as the run goes.
//!
//! Two threads pay only when moving each car's data between the cores costs less than the work
//! they share. On a machine whose two cores share a cache they do (dense_road about 1.4× one
//! thread's speed); where the two cores sit far apart (a virtual machine's two cores placed on
//! different dies by its host, a handover round trip ten times as long) the same step on two
//! threads ran slower than on one, and the host may move them while a run goes. So the step
//! is timed in short blocks with the split allowed and not, alternated, and the faster way is
//! kept for a while before the next trial. Which thread does a car's work never changes a
//! result (see [`for_each_car`](crate::for_each_car)), so the choice touches only the wall time.

use std::cell::Cell;
use std::time::{Duration, Instant};

/// The environment variable that chooses how the step decides to split its passes: `auto` (the
/// default) times both ways as the run goes, `always` splits every pass as its thresholds say
/// (for timing the split itself, and for tests of it).
pub const SPLIT_ENV: &str = "FLOCKWAY_SPLIT";

/// How [`SPLIT_ENV`] asks the step to split: `Ok(true)` for `always`, `Ok(false)` for `auto` or
/// not set, an error that says why for anything else.
pub fn split_always_from_env() -> Result<bool, String> {
    match std::env::var(SPLIT_ENV) {
        Err(std::env::VarError::NotPresent) => Ok(false),
        Ok(v) if v.trim() == "auto" => Ok(false),
        Ok(v) if v.trim() == "always" => Ok(true),
        Ok(v) => Err(format!("{SPLIT_ENV}={v:?}: expected auto or always")),
        Err(std::env::VarError::NotUnicode(v)) => {
            Err(format!("{SPLIT_ENV}={v:?}: expected auto or always"))
        }
    }
}

thread_local! {
    /// Whether passes started on this thread may split (what the step stepping on it chose).
    static ALLOWED: Cell<bool> = const { Cell::new(true) };
    /// How many passes started on this thread have split, to tell a trial that split nothing.
    static SPLITS: Cell<u64> = const { Cell::new(0) };
}

/// Whether a pass started on this thread may split over the threads.
pub(crate) fn split_allowed() -> bool {
    ALLOWED.with(Cell::get)
}

/// Notes that a pass started on this thread split.
pub(crate) fn note_split() {
    SPLITS.with(|s| s.set(s.get() + 1));
}

/// `f` with the passes it starts kept on this thread, as a step the tuner keeps there.
#[cfg(test)]
pub(crate) fn keep_one_thread_for_test<R>(f: impl FnOnce() -> R) -> R {
    let before = ALLOWED.with(|a| a.replace(false));
    let answer = f();
    ALLOWED.with(|a| a.set(before));
    answer
}

/// The most steps timed in a row one way before the trial switches to the other.
const BLOCK_STEPS: u32 = 8;

/// How long a trial's block should last at least: steps of a large level (milliseconds each)
/// are timed one at a time, those of a small one in runs long enough to time.
const BLOCK_TIME: Duration = Duration::from_micros(500);

/// The ways of a trial's blocks, split (`true`) or not: each way first as often as last, so a
/// step time that drifts through a trial weighs on both alike.
const TRIAL: [bool; 8] = [true, false, false, true, false, true, true, false];

/// Trials' lengths the faster way is kept for before the next trial: long enough that the
/// trial's steps the slower way cost little (1.5 % of the steps), short enough to follow a
/// machine that changes while a run goes (2 048 steps with blocks of 8, 256 with blocks of one).
const KEEP_TRIALS: u32 = 32;
/// Trials' lengths a trial's choice is kept for when the trial could not tell much: no pass
/// split (a level too small for its passes to split), or the two ways took nearly the same time
/// ([`CLOSE_CALL`]; a level filling up, whose passes gain more from the split with each car
/// that comes). The next trial comes soon, and costs little while the ways stay close.
const KEEP_UNSURE_TRIALS: u32 = 4;
/// How near the two ways' times make a trial a close call, as a share of the faster way's. A
/// close call kept for [`KEEP_TRIALS`] held `dense_road` on one thread from about its 35th car
/// to its 100th: a trial at 35 cars had found one thread under 1 % faster.
const CLOSE_CALL: f64 = 0.05;
/// Steps the split is allowed before the first trial: a run's first steps do one-off work
/// (the first search of every car's road, the pools' threads starting) that says nothing of
/// the steps after.
const WARM_STEPS: u32 = 120;

/// Where the tuner is: timing a trial's blocks, or keeping what one chose.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// In block `block` of the trial, `step` steps into it.
    Trial { block: usize, step: u32 },
    /// Keeping `split` for `left` more steps.
    Keep { split: bool, left: u32 },
}

/// Chooses, step by step, whether a [`Sim`](crate::Sim)'s passes split over the threads, from
/// the wall time of its steps (see the module's documentation).
#[derive(Debug, Clone)]
pub struct SplitTuner {
    /// `false` when the passes always split as their thresholds say (one thread, or
    /// [`SPLIT_ENV`]`=always`, or a forced threshold): nothing is timed.
    tuning: bool,
    phase: Phase,
    /// Steps in each block of the current trial.
    block_steps: u32,
    /// The time of each block of the current trial.
    blocks: [Duration; TRIAL.len()],
    /// The time and the count of the steps kept since the last trial, to size the next one's
    /// blocks.
    kept: (Duration, u32),
    /// The thread's count of passes that split, when the trial began.
    splits_at_trial: u64,
}

impl SplitTuner {
    /// A tuner that times the step both ways when `tuning`, and otherwise always allows the
    /// split.
    pub fn new(tuning: bool) -> SplitTuner {
        SplitTuner {
            tuning,
            phase: Phase::Keep {
                split: true,
                left: WARM_STEPS,
            },
            block_steps: BLOCK_STEPS,
            blocks: [Duration::ZERO; TRIAL.len()],
            kept: (Duration::ZERO, 0),
            splits_at_trial: 0,
        }
    }

    /// The tuner for a step on this process's pool: timing when the pool has two threads or
    /// more, unless [`SPLIT_ENV`] or [`PARALLEL_MIN_ENV`](crate::PARALLEL_MIN_ENV) (which asks
    /// for every pass to split) says otherwise.
    pub fn for_pool() -> SplitTuner {
        let forced = split_always_from_env().unwrap_or(false)
            || std::env::var_os(crate::PARALLEL_MIN_ENV).is_some();
        SplitTuner::new(crate::pool_threads() >= 2 && !forced)
    }

    /// Whether the coming step's passes may split.
    fn split_now(&self) -> bool {
        match self.phase {
            _ if !self.tuning => true,
            Phase::Trial { block, .. } => TRIAL[block],
            Phase::Keep { split, .. } => split,
        }
    }

    /// Whether the coming step belongs to a trial.
    #[cfg(test)]
    fn timing(&self) -> bool {
        self.tuning && matches!(self.phase, Phase::Trial { .. })
    }

    /// Runs `step` with this thread's passes split or not as the tuner chooses, timing it.
    pub fn run(&mut self, step: impl FnOnce()) {
        self.run_timed(|| {
            // Wall time, read only to choose between two ways that give the same bytes: it
            // decides which thread does a car's work, never what the work computes.
            let started = Instant::now();
            step();
            started.elapsed()
        });
    }

    /// [`run`](Self::run) with `step` returning its own time.
    fn run_timed(&mut self, step: impl FnOnce() -> Duration) {
        let split = self.split_now();
        if matches!(self.phase, Phase::Trial { block: 0, step: 0 }) {
            self.splits_at_trial = SPLITS.with(Cell::get);
        }
        let before = ALLOWED.with(|a| a.replace(split));
        let elapsed = step();
        ALLOWED.with(|a| a.set(before));
        self.record(elapsed, SPLITS.with(Cell::get) > self.splits_at_trial);
    }

    /// Takes a step's time into account: `split_any` tells whether any pass has split since
    /// the trial began.
    fn record(&mut self, elapsed: Duration, split_any: bool) {
        if !self.tuning {
            return;
        }
        match &mut self.phase {
            Phase::Trial { block, step } => {
                self.blocks[*block] += elapsed;
                *step += 1;
                if *step < self.block_steps {
                    return;
                }
                *step = 0;
                *block += 1;
                if *block < TRIAL.len() {
                    return;
                }
                let (with, without) = self.way_times();
                // Nothing split: the two ways ran the same step; keep the split allowed (the
                // way without a tuner) and look again soon.
                let split = !split_any || with <= without;
                tracing::debug!(
                    "split trial: {:.3} ms with the passes split, {:.3} ms on one thread \
                     (blocks of {} steps, the middle two of four each way{}): {}",
                    with.as_secs_f64() * 1e3,
                    without.as_secs_f64() * 1e3,
                    self.block_steps,
                    if split_any { "" } else { ", nothing split" },
                    if split { "split" } else { "one thread" },
                );
                let trial_steps = TRIAL.len() as u32 * self.block_steps;
                let close = with.abs_diff(without).as_secs_f64()
                    <= CLOSE_CALL * with.min(without).as_secs_f64();
                let trials = if split_any && !close {
                    KEEP_TRIALS
                } else {
                    KEEP_UNSURE_TRIALS
                };
                self.phase = Phase::Keep {
                    split,
                    left: trials * trial_steps,
                };
                self.kept = (Duration::ZERO, 0);
            }
            Phase::Keep { left, .. } => {
                self.kept.0 += elapsed;
                self.kept.1 += 1;
                *left -= 1;
                if *left == 0 {
                    self.begin_trial();
                }
            }
        }
    }

    /// Starts a trial, its blocks as long as [`BLOCK_TIME`] at the speed the steps were kept at.
    fn begin_trial(&mut self) {
        let (time, steps) = self.kept;
        let step = time / steps.max(1);
        self.block_steps = if step.is_zero() {
            BLOCK_STEPS
        } else {
            // Rounded up, so a block never lasts less than BLOCK_TIME.
            let n = BLOCK_TIME.as_nanos().div_ceil(step.as_nanos().max(1));
            n.clamp(1, u128::from(BLOCK_STEPS)) as u32
        };
        self.blocks = [Duration::ZERO; TRIAL.len()];
        self.phase = Phase::Trial { block: 0, step: 0 };
    }

    /// The trial's time each way, split and on one thread: the sum of the middle two of its
    /// four blocks, so one step slowed by something else (a page fault, the host taking the
    /// core) does not decide the trial.
    fn way_times(&self) -> (Duration, Duration) {
        let way = |split: bool| {
            let mut times: Vec<Duration> = TRIAL
                .iter()
                .zip(&self.blocks)
                .filter(|(w, _)| **w == split)
                .map(|(_, t)| *t)
                .collect();
            times.sort_unstable();
            times[1] + times[2]
        };
        (way(true), way(false))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Steps `tuner` `n` times, each step taking what `time` says for whether its passes may
    /// split (and splitting when allowed, as `splits` says); returns how many were allowed to
    /// split.
    fn drive_with(
        tuner: &mut SplitTuner,
        n: usize,
        splits: bool,
        mut time: impl FnMut(bool) -> Duration,
    ) -> usize {
        let mut allowed = 0;
        for _ in 0..n {
            tuner.run_timed(|| {
                let split = split_allowed();
                if split && splits {
                    note_split();
                }
                allowed += usize::from(split);
                time(split)
            });
        }
        allowed
    }

    /// [`drive_with`], each step taking `with` or `without` milliseconds.
    fn drive(tuner: &mut SplitTuner, n: usize, with: u64, without: u64, splits: bool) -> usize {
        drive_with(tuner, n, splits, |split| {
            Duration::from_millis(if split { with } else { without })
        })
    }

    /// A trial's steps once the steps are long enough to be timed one at a time.
    const TRIAL_STEPS: usize = TRIAL.len();
    const KEEP: usize = KEEP_TRIALS as usize * TRIAL_STEPS;

    #[test]
    fn the_faster_way_is_kept_until_the_next_trial_and_the_choice_follows_the_machine() {
        let mut tuner = SplitTuner::new(true);
        // A run's first steps split, untimed.
        let warm = WARM_STEPS as usize;
        assert_eq!(drive(&mut tuner, warm, 6, 10, true), warm);
        // Splitting is faster: after the trial (half of it split), every step splits.
        assert!(tuner.timing());
        assert_eq!(drive(&mut tuner, TRIAL_STEPS, 6, 10, true), TRIAL_STEPS / 2);
        assert!(!tuner.timing());
        assert_eq!(drive(&mut tuner, KEEP, 6, 10, true), KEEP);
        // The machine changes: one thread is faster now; the next trial sees it.
        assert!(tuner.timing());
        assert_eq!(
            drive(&mut tuner, TRIAL_STEPS, 12, 10, true),
            TRIAL_STEPS / 2
        );
        assert_eq!(drive(&mut tuner, KEEP, 12, 10, true), 0);
        // The passes are restored to their default once a step is over.
        assert!(split_allowed());
    }

    #[test]
    fn one_slow_step_does_not_decide_a_trial() {
        let mut tuner = SplitTuner::new(true);
        drive(&mut tuner, WARM_STEPS as usize, 5, 10, true);
        // The trial's first step (split) is held up a second; the split still wins.
        let mut first = true;
        drive_with(&mut tuner, TRIAL_STEPS, true, |split| {
            let ms = match split {
                true if std::mem::take(&mut first) => 1_000,
                true => 5,
                false => 10,
            };
            Duration::from_millis(ms)
        });
        assert_eq!(drive(&mut tuner, KEEP, 5, 10, true), KEEP);
    }

    #[test]
    fn short_steps_are_timed_in_blocks_long_enough_to_time() {
        // 100 µs a step: blocks of five; 10 µs: of eight, the most.
        for (us, block) in [(100, 5), (10, BLOCK_STEPS)] {
            let mut tuner = SplitTuner::new(true);
            let step = |split: bool| Duration::from_micros(if split { us } else { 2 * us });
            drive_with(&mut tuner, WARM_STEPS as usize, true, step);
            let trial = TRIAL.len() * block as usize;
            assert_eq!(drive_with(&mut tuner, trial, true, step), trial / 2);
            assert!(!tuner.timing(), "{us} µs a step");
            let keep = KEEP_TRIALS as usize * trial;
            assert_eq!(drive_with(&mut tuner, keep, true, step), keep);
            assert!(tuner.timing());
        }
    }

    #[test]
    fn a_splitless_trial_keeps_the_split_allowed_only_briefly() {
        // Nothing split in the trial (a level too small): the split stays allowed, as without
        // a tuner, whatever the noise said, and the next trial comes soon.
        let mut tuner = SplitTuner::new(true);
        drive(&mut tuner, WARM_STEPS as usize, 20, 10, false);
        drive(&mut tuner, TRIAL_STEPS, 20, 10, false);
        let unsure = KEEP_UNSURE_TRIALS as usize * TRIAL_STEPS;
        assert_eq!(drive(&mut tuner, unsure, 20, 10, false), unsure);
        assert!(tuner.timing());
    }

    #[test]
    fn a_close_call_keeps_the_faster_way_only_until_a_trial_comes_soon() {
        let mut tuner = SplitTuner::new(true);
        drive(&mut tuner, WARM_STEPS as usize, 103, 100, true);
        // 3 % apart: one thread, the faster, but looked at again after a few trials' lengths.
        drive(&mut tuner, TRIAL_STEPS, 103, 100, true);
        let unsure = KEEP_UNSURE_TRIALS as usize * TRIAL_STEPS;
        assert_eq!(drive(&mut tuner, unsure, 103, 100, true), 0);
        assert!(tuner.timing());
        // The level has filled up: the split is clearly faster now, and kept as long as any.
        drive(&mut tuner, TRIAL_STEPS, 80, 100, true);
        assert_eq!(drive(&mut tuner, KEEP, 80, 100, true), KEEP);
        assert!(tuner.timing());
        // 10 % apart is no close call: one thread, kept as long as any.
        drive(&mut tuner, TRIAL_STEPS, 110, 100, true);
        assert_eq!(drive(&mut tuner, KEEP, 110, 100, true), 0);
        assert!(tuner.timing());
    }

    #[test]
    fn without_tuning_every_step_may_split_and_nothing_is_timed() {
        let mut tuner = SplitTuner::new(false);
        assert!(!tuner.timing());
        assert_eq!(drive(&mut tuner, 5_000, 20, 10, true), 5_000);
    }
}
