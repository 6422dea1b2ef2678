//! Seeded randomness: one ChaCha stream per stable id, derived from the level seed.

use crate::StableId;
use bevy_ecs::{component::Component, resource::Resource};
use rand_chacha::ChaCha8Rng;
use rand_core::{Rng, SeedableRng};

/// The run's seed, from which every entity's independent random stream is derived.
#[derive(Resource, Debug, Clone, Copy, PartialEq, Eq)]
pub struct RngStreams {
    seed: u64,
}

impl RngStreams {
    /// Streams for a run with this seed.
    pub fn new(seed: u64) -> RngStreams {
        RngStreams { seed }
    }

    /// The run's seed.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The random stream that belongs to `id`: the same for the same seed and id, independent of
    /// every other id's stream, and of how many entities exist or in what order they were made.
    pub fn stream(&self, id: StableId) -> EntityRng {
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        // ChaCha's 64-bit stream selector gives 2^64 non-overlapping sequences for one key.
        rng.set_stream(id.stream());
        EntityRng { rng }
    }
}

/// An entity's own random stream. Draw from it only in a deterministic order (a system that
/// iterates entities in `StableId` order, or an entity drawing from its own stream).
#[derive(Component, Debug, Clone, PartialEq, Eq)]
pub struct EntityRng {
    rng: ChaCha8Rng,
}

impl EntityRng {
    /// The next raw 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.rng.next_u64()
    }

    /// A new stream seeded from this one's next draw: for a part of an entity that draws at its
    /// own pace (e.g. every tick) without shifting the entity's other draws.
    pub fn fork(&mut self) -> EntityRng {
        EntityRng {
            rng: ChaCha8Rng::seed_from_u64(self.rng.next_u64()),
        }
    }

    /// A uniform sample in [0, 1), with 53 bits of precision.
    pub fn unit_f64(&mut self) -> f64 {
        (self.rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// A uniform sample in [lo, hi); returns `lo` when the range is empty.
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        if hi <= lo {
            return lo;
        }
        lo + (hi - lo) * self.unit_f64()
    }

    /// A standard normal sample (mean 0, deviation 1), by the Box–Muller transform from two
    /// uniform draws, with `libm` so it is the same on every machine.
    pub fn normal(&mut self) -> f64 {
        // 1 − u lies in (0, 1]: the logarithm stays finite.
        let u1 = 1.0 - self.unit_f64();
        let u2 = self.unit_f64();
        libm::sqrt(-2.0 * libm::log(u1)) * libm::cos(std::f64::consts::TAU * u2)
    }

    /// Picks an index with probability proportional to `weights` (non-finite or negative weights
    /// count as zero). Returns `None` when no weight is positive.
    pub fn weighted_index(&mut self, weights: &[f64]) -> Option<usize> {
        let clean = |w: f64| if w.is_finite() && w > 0.0 { w } else { 0.0 };
        let total: f64 = weights.iter().copied().map(clean).sum();
        if total <= 0.0 {
            return None;
        }
        let mut target = self.unit_f64() * total;
        let mut last_positive = None;
        for (i, &w) in weights.iter().enumerate() {
            let w = clean(w);
            if w > 0.0 {
                last_positive = Some(i);
                if target < w {
                    return Some(i);
                }
                target -= w;
            }
        }
        // Rounding can leave a sliver past the last bucket; it belongs to the last positive one.
        last_positive
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::IdKind;

    #[test]
    fn normal_draws_have_mean_zero_and_deviation_one() {
        let mut rng = RngStreams::new(3).stream(StableId::new(IdKind::Vehicle, 9));
        let n = 200_000;
        let xs: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 0.01, "{mean}");
        assert!((var.sqrt() - 1.0).abs() < 0.01, "{}", var.sqrt());
        let within_one = xs.iter().filter(|x| x.abs() < 1.0).count() as f64 / n as f64;
        assert!((within_one - 0.6827).abs() < 0.005, "{within_one}");
        assert!(xs.iter().all(|x| x.is_finite()));
    }

    #[test]
    fn same_seed_and_id_give_the_same_stream() {
        let s = RngStreams::new(42);
        let id = StableId::new(IdKind::Vehicle, 3);
        let a: Vec<u64> = (0..8).map(|_| s.stream(id).next_u64()).collect();
        let mut r = s.stream(id);
        let first = r.next_u64();
        assert!(a.iter().all(|&x| x == first));
        let mut r1 = s.stream(id);
        let mut r2 = RngStreams::new(42).stream(id);
        for _ in 0..100 {
            assert_eq!(r1.next_u64(), r2.next_u64());
        }
    }

    #[test]
    fn different_ids_and_seeds_give_different_streams() {
        let s = RngStreams::new(42);
        let a = s.stream(StableId::new(IdKind::Vehicle, 3)).next_u64();
        let b = s.stream(StableId::new(IdKind::Vehicle, 4)).next_u64();
        let c = s.stream(StableId::new(IdKind::Spawner, 3)).next_u64();
        let d = RngStreams::new(43)
            .stream(StableId::new(IdKind::Vehicle, 3))
            .next_u64();
        assert!(a != b && a != c && a != d && b != c);
    }

    #[test]
    fn uniform_stays_in_range_and_covers_it() {
        let mut r = RngStreams::new(1).stream(StableId::new(IdKind::Custom, 0));
        let xs: Vec<f64> = (0..10_000).map(|_| r.uniform(-0.1, 0.1)).collect();
        assert!(xs.iter().all(|&x| (-0.1..0.1).contains(&x)));
        let min = xs.iter().copied().fold(f64::INFINITY, f64::min);
        let max = xs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        assert!(min < -0.099 && max > 0.099, "min {min} max {max}");
        let mean = xs.iter().sum::<f64>() / xs.len() as f64;
        assert!(mean.abs() < 0.003, "mean {mean}");
        assert_eq!(r.uniform(2.0, 2.0), 2.0);
    }

    #[test]
    fn weighted_index_follows_the_weights() {
        let mut r = RngStreams::new(7).stream(StableId::new(IdKind::Custom, 1));
        let mut counts = [0usize; 3];
        for _ in 0..30_000 {
            counts[r.weighted_index(&[1.0, 0.0, 3.0]).unwrap_or(99)] += 1;
        }
        assert_eq!(counts[1], 0);
        let share = counts[2] as f64 / 30_000.0;
        assert!((share - 0.75).abs() < 0.02, "share {share}");
        assert_eq!(r.weighted_index(&[0.0, f64::NAN, -1.0]), None);
    }
}
