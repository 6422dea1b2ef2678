//! The fixed-step clock: time is a tick count, never an accumulated float.

use bevy_ecs::resource::Resource;

/// Fixed steps per simulated second.
pub const TICKS_PER_SECOND: u32 = 120;

/// Length of one fixed step in seconds (1/120 s).
pub const DT_S: f64 = 1.0 / TICKS_PER_SECOND as f64;

/// A point in simulated time, counted in fixed steps since the start of the run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Tick(pub u64);

impl Tick {
    /// The simulated time of this tick in seconds.
    pub fn seconds(self) -> f64 {
        // Exact for any run shorter than 2^53 ticks (~2.4 million years): no drift accumulates.
        self.0 as f64 / f64::from(TICKS_PER_SECOND)
    }

    /// The first tick at or after `seconds` of simulated time (negative and NaN give tick 0).
    pub fn at_or_after(seconds: f64) -> Tick {
        let ticks = (seconds * f64::from(TICKS_PER_SECOND) - 1e-9).ceil();
        if ticks.is_nan() || ticks <= 0.0 {
            Tick(0)
        } else {
            Tick(ticks as u64)
        }
    }

    /// Whether this tick falls on a multiple of `period_ticks` (a period of 0 never matches).
    pub fn is_multiple_of(self, period_ticks: u64) -> bool {
        period_ticks != 0 && self.0.is_multiple_of(period_ticks)
    }
}

/// The simulation clock: the tick being simulated now. The [`Sim`](crate::Sim) advances it after
/// every step; systems read it and never write it.
#[derive(Resource, Debug, Clone, Copy, Default)]
pub struct SimClock {
    tick: Tick,
}

impl SimClock {
    /// The tick the current step simulates (0 during the first step).
    pub fn tick(&self) -> Tick {
        self.tick
    }

    /// Simulated seconds elapsed before the current step.
    pub fn seconds(&self) -> f64 {
        self.tick.seconds()
    }

    /// Length of one step in seconds.
    pub fn dt_s(&self) -> f64 {
        DT_S
    }

    pub(crate) fn advance(&mut self) {
        self.tick.0 += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_seconds_are_exact_multiples_of_the_step() {
        assert_eq!(Tick(0).seconds(), 0.0);
        assert_eq!(Tick(60).seconds(), 0.5);
        assert_eq!(Tick(120 * 3600).seconds(), 3600.0);
    }

    #[test]
    fn at_or_after_rounds_up_to_the_next_tick() {
        assert_eq!(Tick::at_or_after(0.5), Tick(60));
        assert_eq!(Tick::at_or_after(0.501), Tick(61));
        assert_eq!(Tick::at_or_after(-1.0), Tick(0));
        assert_eq!(Tick::at_or_after(f64::NAN), Tick(0));
        // 0.1 is not representable; it must still map to tick 12, not 13.
        assert_eq!(Tick::at_or_after(0.1), Tick(12));
    }

    #[test]
    fn multiples() {
        assert!(Tick(120).is_multiple_of(60));
        assert!(!Tick(121).is_multiple_of(60));
        assert!(!Tick(0).is_multiple_of(0));
    }
}
