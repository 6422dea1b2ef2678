//! Wall-clock pacing for interactive runs: decides how many fixed steps a frame runs.
//!
//! Wall time only decides *how many* ticks run, never what a tick computes, so a window run gives
//! the same results as a headless one.

use std::time::Duration;

/// How fast an interactive run goes relative to wall time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpeedSetting {
    /// No steps run.
    Paused,
    /// `n` simulated seconds per wall second (1×, 2×, 5×, …).
    Times(u32),
    /// As many steps as the frame budget allows.
    Max,
}

/// A fixed-step accumulator in integer units of wall time (no float drift).
#[derive(Debug, Clone)]
pub struct FixedStepper {
    speed: SpeedSetting,
    accumulated: u128,
    /// Most ticks one frame may run, so a slow frame cannot snowball into ever slower frames.
    pub max_ticks_per_frame: u64,
}

/// 1e9 / 120 ns is not an integer, so wall time is accumulated in units of 1/120 ns: one tick is
/// then exactly 1e9 units and no rounding error ever builds up.
const UNITS_PER_TICK: u128 = 1_000_000_000;

impl FixedStepper {
    /// A stepper at the given speed.
    pub fn new(speed: SpeedSetting) -> FixedStepper {
        FixedStepper {
            speed,
            accumulated: 0,
            max_ticks_per_frame: 240,
        }
    }

    /// The current speed.
    pub fn speed(&self) -> SpeedSetting {
        self.speed
    }

    /// Changes the speed; time accumulated under the old speed is dropped.
    pub fn set_speed(&mut self, speed: SpeedSetting) {
        self.speed = speed;
        self.accumulated = 0;
    }

    /// Ticks due after `wall` more wall time has passed. For [`SpeedSetting::Max`] this is
    /// `max_ticks_per_frame`, and the caller stops early when its frame budget runs out.
    pub fn ticks_due(&mut self, wall: Duration) -> u64 {
        match self.speed {
            SpeedSetting::Paused => 0,
            SpeedSetting::Max => self.max_ticks_per_frame,
            SpeedSetting::Times(factor) => {
                self.accumulated +=
                    wall.as_nanos() * u128::from(factor) * u128::from(crate::TICKS_PER_SECOND);
                let due = self.accumulated / UNITS_PER_TICK;
                let capped = due.min(u128::from(self.max_ticks_per_frame));
                self.accumulated -= capped * UNITS_PER_TICK;
                if due > capped {
                    // Behind by more than a frame's worth: forget the backlog rather than chase it.
                    self.accumulated = 0;
                }
                capped as u64
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn real_time_runs_120_ticks_per_second_without_drift() {
        let mut s = FixedStepper::new(SpeedSetting::Times(1));
        let frame = Duration::from_nanos(16_666_667);
        let total: u64 = (0..60 * 60).map(|_| s.ticks_due(frame)).sum();
        // One wall minute (plus 12 µs of rounding in the frame length) is 7200 ticks.
        assert_eq!(total, 7200);
    }

    #[test]
    fn speed_multiplies_and_pause_stops() {
        let mut s = FixedStepper::new(SpeedSetting::Times(5));
        assert_eq!(s.ticks_due(Duration::from_millis(100)), 60);
        s.set_speed(SpeedSetting::Paused);
        assert_eq!(s.ticks_due(Duration::from_secs(1)), 0);
        s.set_speed(SpeedSetting::Max);
        assert_eq!(s.ticks_due(Duration::from_millis(1)), s.max_ticks_per_frame);
    }

    #[test]
    fn a_long_stall_is_capped_and_forgotten() {
        let mut s = FixedStepper::new(SpeedSetting::Times(1));
        assert_eq!(s.ticks_due(Duration::from_secs(10)), 240);
        assert_eq!(s.ticks_due(Duration::from_millis(0)), 0);
    }
}
