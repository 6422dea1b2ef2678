//! Stop-and-go wave measurement from a run's trajectories.
//!
//! The method, in four steps (documented in the README):
//! 1. **Speed field.** On the road with the most samples, at every sample time from the start of
//!    the analysis window, the speed is interpolated linearly between consecutive vehicles (by arc
//!    position, around the loop on a closed road) onto cells of [`WaveSettings::cell_m`]. Each
//!    time's mean is subtracted, leaving the pattern of slow and fast traffic `D(x, t)`.
//! 2. **Amplitude.** The root-mean-square of `D` over the window, in km/h.
//! 3. **Propagation speed.** For each candidate speed `c` the pattern is shifted by `c·τ` for lags
//!    `τ` of 2, 4, 6 and 8 s and correlated with itself (normalised, 1 = identical). The `c` with
//!    the highest correlation is the wave speed: negative means against the traffic.
//! 4. **Period.** The time autocorrelation of `D` at fixed points, averaged over the road: its
//!    first peak after it has turned negative is the period a fixed observer sees.
//!
//! A stop-and-go wave is *detected* when the pattern is strong (amplitude at least
//! [`WaveSettings::min_relative_amplitude`] of the mean speed), coherent (correlation at least
//! [`WaveSettings::min_correlation`]) and travels against the traffic (`c` below
//! −[`WaveSettings::min_speed_kmh`]). Speed patterns that vehicles carry along with them, or that
//! stand still on the road (braking for a bend), are not stop-and-go waves.

use crate::Trace;
use multiversion::multiversion;
use std::collections::BTreeMap;
use wide::{f64x2, f64x4};

/// Tuning of [`measure_wave`]; the defaults are the documented method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WaveSettings {
    /// Start of the analysis window, simulated seconds (the warm-up before it is ignored).
    pub from_s: f64,
    /// Cell length of the speed field, metres.
    pub cell_m: f64,
    /// Smallest pattern amplitude that counts, as a share of the mean speed.
    pub min_relative_amplitude: f64,
    /// Smallest correlation of the shifted pattern that counts as coherent.
    pub min_correlation: f64,
    /// Slowest upstream propagation that counts as a travelling wave, km/h.
    pub min_speed_kmh: f64,
}

impl Default for WaveSettings {
    fn default() -> Self {
        WaveSettings {
            from_s: 0.0,
            cell_m: 2.0,
            min_relative_amplitude: 0.10,
            min_correlation: 0.5,
            min_speed_kmh: 2.0,
        }
    }
}

/// What [`measure_wave`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct Wave {
    /// The road measured (the one with the most samples in the window).
    pub road: String,
    /// Whether the road is a loop (vehicles wrap around).
    pub closed: bool,
    /// Road length used for the field, metres.
    pub length_m: f64,
    /// Mean speed over the window, km/h.
    pub mean_speed_kmh: f64,
    /// Root-mean-square of the speed pattern, km/h.
    pub amplitude_kmh: f64,
    /// Best propagation speed of the pattern, km/h (negative: against the traffic).
    pub best_speed_kmh: f64,
    /// Correlation of the pattern shifted at [`Wave::best_speed_kmh`] (1 = moves unchanged).
    pub correlation: f64,
    /// Period at a fixed point, seconds, if the pattern repeats within the window.
    pub best_period_s: Option<f64>,
    /// Whether the pattern is a stop-and-go wave (see the module docs).
    pub detected: bool,
}

impl Wave {
    /// The wave's propagation speed, km/h, if one was detected.
    pub fn speed_kmh(&self) -> Option<f64> {
        self.detected.then_some(self.best_speed_kmh)
    }

    /// The wave's period at a fixed point, seconds, if one was detected and repeats.
    pub fn period_s(&self) -> Option<f64> {
        if self.detected {
            self.best_period_s
        } else {
            None
        }
    }
}

/// How many threads the wave measurement's trial speeds are split over: `FLOCKWAY_THREADS` where
/// it is a whole number from 1 to 1024 (the count the simulation's passes accept; the command line
/// refuses any other before a run starts), else one per core.
fn analysis_threads() -> usize {
    std::env::var("FLOCKWAY_THREADS")
        .ok()
        .and_then(|v| v.trim().parse::<usize>().ok())
        .filter(|n| (1..=1024).contains(n))
        .or_else(|| std::thread::available_parallelism().ok().map(usize::from))
        .unwrap_or(1)
}

/// Lags the pattern is followed over, seconds.
const LAGS_S: [f64; 4] = [2.0, 4.0, 6.0, 8.0];

/// Measures the stop-and-go wave on the busiest road of a run. `road_lengths` gives known road
/// lengths by name (from the run's summary); without one, a loop's length is estimated from the
/// vehicles wrapping around it. `None` if fewer than two vehicles share a road in the window.
pub fn measure_wave(
    trace: &Trace,
    road_lengths: &BTreeMap<String, f64>,
    settings: &WaveSettings,
) -> Option<Wave> {
    let window: Vec<_> = trace
        .samples()
        .iter()
        .filter(|s| s.time_s >= settings.from_s - 1e-9)
        .collect();
    let mut count = vec![0usize; trace.roads().len()];
    for s in &window {
        count[usize::from(s.road)] += 1;
    }
    // Ties go to the first road named, so the choice is stable.
    let road = (0..count.len()).max_by_key(|&i| (count[i], std::cmp::Reverse(i)))? as u16;
    let name = trace.roads()[usize::from(road)].clone();
    let (closed, estimated) = loop_length(trace, road);
    let max_s = window
        .iter()
        .filter(|s| s.road == road)
        .map(|s| s.s_m)
        .fold(0.0, f64::max);
    let length_m = road_lengths
        .get(&name)
        .copied()
        .or(estimated)
        .unwrap_or(max_s)
        .max(max_s)
        .max(settings.cell_m);

    // Sample times and their vehicles on the road.
    let mut frames: Vec<(f64, Vec<(f64, f64)>)> = Vec::new();
    for s in window.iter().filter(|s| s.road == road) {
        match frames.last_mut() {
            Some((t, v)) if *t == s.time_s => v.push((s.s_m, s.speed_kmh)),
            _ => frames.push((s.time_s, vec![(s.s_m, s.speed_kmh)])),
        }
    }
    frames.retain(|(_, v)| v.len() >= 2);
    if frames.len() < 2 {
        return None;
    }
    let dt = median_step(&frames.iter().map(|f| f.0).collect::<Vec<_>>());
    let cells = (length_m / settings.cell_m).ceil() as usize;
    let cell_m = length_m / cells as f64;

    // The field, one row per sample time on a regular time grid (missing rows stay NaN).
    let t0 = frames[0].0;
    let rows = ((frames[frames.len() - 1].0 - t0) / dt).round() as usize + 1;
    let mut field = vec![f64::NAN; rows * cells];
    let mut speed_sum = 0.0;
    let mut speed_n = 0usize;
    for (t, vehicles) in &mut frames {
        let row = ((*t - t0) / dt).round() as usize;
        vehicles.sort_by(|a, b| a.0.total_cmp(&b.0));
        speed_sum += vehicles.iter().map(|v| v.1).sum::<f64>();
        speed_n += vehicles.len();
        let out = &mut field[row * cells..(row + 1) * cells];
        fill_row(out, vehicles, cell_m, length_m, closed);
        let valid: Vec<f64> = out.iter().copied().filter(|v| v.is_finite()).collect();
        let mean = valid.iter().sum::<f64>() / valid.len().max(1) as f64;
        for v in out.iter_mut() {
            *v -= mean;
        }
    }
    let mean_speed_kmh = speed_sum / speed_n.max(1) as f64;
    let (sq, n) = field
        .iter()
        .filter(|v| v.is_finite())
        .fold((0.0, 0usize), |(a, n), v| (a + v * v, n + 1));
    let amplitude_kmh = (sq / n.max(1) as f64).sqrt();

    // Propagation: the best speed on a 0.5 km/h grid, then refined to 0.05 km/h.
    let fastest = frames
        .iter()
        .flat_map(|f| f.1.iter().map(|v| v.1))
        .fold(0.0, f64::max);
    let hi = 60f64.max(1.2 * fastest);
    let grid = Grid {
        field: &field,
        rows,
        cells,
        cell_m,
        dt,
        closed,
        moderate: moderate(&field),
    };
    let threads = analysis_threads();
    let mut best = (-60.0, f64::NEG_INFINITY);
    let mut speeds = Vec::new();
    let mut c = -60.0;
    while c <= hi + 1e-9 {
        speeds.push(c);
        c += 0.5;
    }
    for (&c, r) in speeds.iter().zip(grid.correlations(&speeds, threads)) {
        if r > best.1 {
            best = (c, r);
        }
    }
    let coarse = best.0;
    let fine: Vec<f64> = (-10..=10).map(|k| coarse + f64::from(k) * 0.05).collect();
    for (&c, r) in fine.iter().zip(grid.correlations(&fine, threads)) {
        if r > best.1 {
            best = (c, r);
        }
    }
    let (best_speed_kmh, correlation) = best;
    let best_period_s = grid.period_s(threads);
    let detected = amplitude_kmh >= settings.min_relative_amplitude * mean_speed_kmh
        && correlation >= settings.min_correlation
        && best_speed_kmh <= -settings.min_speed_kmh;
    Some(Wave {
        road: name,
        closed,
        length_m,
        mean_speed_kmh,
        amplitude_kmh,
        best_speed_kmh,
        correlation: if correlation.is_finite() {
            correlation
        } else {
            0.0
        },
        best_period_s,
        detected,
    })
}

/// Whether vehicles wrap around `road` (a loop), and its length estimated from the wraps: the
/// distance a wrapping vehicle covers between two samples, added to where it left off.
fn loop_length(trace: &Trace, road: u16) -> (bool, Option<f64>) {
    let mut estimates = Vec::new();
    for samples in trace.by_vehicle().values() {
        for w in samples.windows(2) {
            let (a, b) = (w[0], w[1]);
            if a.road == road && b.road == road && b.s_m + 1.0 < a.s_m {
                let travelled = 0.5 * (a.speed_kmh + b.speed_kmh) / 3.6 * (b.time_s - a.time_s);
                estimates.push(a.s_m - b.s_m + travelled);
            }
        }
    }
    if estimates.is_empty() {
        return (false, None);
    }
    estimates.sort_by(f64::total_cmp);
    (true, Some(estimates[estimates.len() / 2]))
}

fn median_step(times: &[f64]) -> f64 {
    let mut steps: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    steps.get(steps.len() / 2).copied().unwrap_or(1.0).max(1e-3)
}

/// Interpolates speeds between consecutive vehicles onto cell centres.
fn fill_row(out: &mut [f64], vehicles: &[(f64, f64)], cell_m: f64, length_m: f64, closed: bool) {
    let n = vehicles.len();
    for (i, cell) in out.iter_mut().enumerate() {
        let x = (i as f64 + 0.5) * cell_m;
        // The first vehicle at or ahead of x.
        let j = vehicles.partition_point(|v| v.0 < x);
        let (behind, ahead) = match (j, closed) {
            (0, true) => (
                (vehicles[n - 1].0 - length_m, vehicles[n - 1].1),
                vehicles[0],
            ),
            (j, true) if j == n => (vehicles[n - 1], (vehicles[0].0 + length_m, vehicles[0].1)),
            (0, false) => continue,
            (j, false) if j == n => continue,
            (j, _) => (vehicles[j - 1], vehicles[j]),
        };
        let span = ahead.0 - behind.0;
        *cell = if span > 1e-9 {
            behind.1 + (ahead.1 - behind.1) * (x - behind.0) / span
        } else {
            0.5 * (behind.1 + ahead.1)
        };
    }
}

struct Grid<'a> {
    field: &'a [f64],
    rows: usize,
    cells: usize,
    cell_m: f64,
    dt: f64,
    closed: bool,
    /// Whether every value of `field` is NaN or at most [`MODERATE_ABS`] across.
    moderate: bool,
}

impl Grid<'_> {
    /// The normalised correlation of the pattern with itself moved at each of `speeds`, over all
    /// lags, in their order, split over up to `threads` threads: each speed's sums are its own,
    /// so the answers are the same on any number.
    fn correlations(&self, speeds: &[f64], threads: usize) -> Vec<f64> {
        let part = speeds.len().div_ceil(threads.max(1)).max(1);
        let chunks: Vec<&[f64]> = speeds.chunks(part).collect();
        on_threads(chunks.len(), |t| self.correlations_here(chunks[t])).concat()
    }

    /// Normalised correlation of the pattern with itself moved at `c_kmh`, over all lags.
    #[cfg(test)]
    fn correlation(&self, c_kmh: f64) -> f64 {
        self.correlations_here(&[c_kmh])[0]
    }

    /// The correlations of [`correlations`](Self::correlations) at each of `speeds`, on this
    /// thread.
    ///
    /// Each speed's sums run over the lags in order, the rows in order and along each row in
    /// cell order, as a plain walk of every cell would take them: only the cells whose moved
    /// neighbours lie off an open road (which add nothing) are not visited, so each answer is
    /// that walk's to the bit. Speeds whose pattern moves by the same whole number of cells at a
    /// lag (neighbouring trial speeds often do) read the same cells: up to [`SPEED_LANES`] of
    /// them are summed side by side in one walk, each in its own sums.
    fn correlations_here(&self, speeds: &[f64]) -> Vec<f64> {
        let mut sums = vec![[0.0; 3]; speeds.len()];
        for lag_s in LAGS_S {
            let lag = (lag_s / self.dt).round() as usize;
            if lag == 0 || lag >= self.rows {
                continue;
            }
            // The pattern moves by the same distance at every cell, so the interpolation
            // weights are the same along a row: only the indices move.
            let shifts: Vec<(i64, f64)> = speeds
                .iter()
                .map(|&c_kmh| {
                    let shift_cells = c_kmh / 3.6 * lag as f64 * self.dt / self.cell_m;
                    let k = shift_cells.floor();
                    (k as i64, shift_cells - k)
                })
                .collect();
            let mut start = 0;
            while start < speeds.len() {
                let k = shifts[start].0;
                let end = start
                    + shifts[start..]
                        .iter()
                        .take(SPEED_LANES)
                        .take_while(|s| s.0 == k)
                        .count();
                let moved: Vec<f64> = shifts[start..end].iter().map(|s| s.1).collect();
                // A group of one or two takes half-width vectors: half the work a lane.
                if moved.len() <= 2 {
                    add_moved_lag::<f64x2>(self, lag, k, &moved, &mut sums[start..end]);
                } else {
                    add_moved_lag::<f64x4>(self, lag, k, &moved, &mut sums[start..end]);
                }
                start = end;
            }
        }
        sums.iter()
            .map(|&sums| normalised(sums).unwrap_or(f64::NEG_INFINITY))
            .collect()
    }

    /// The first peak of the fixed-point autocorrelation after it has turned negative.
    fn period_s(&self, threads: usize) -> Option<f64> {
        let r = self.autocorrelations(threads);
        let first_negative = r.iter().position(|v| *v < 0.0)?;
        (first_negative.max(1)..r.len().saturating_sub(1)).find_map(|k| {
            let (a, b, c) = (r[k - 1], r[k], r[k + 1]);
            (b > a && b >= c && b > 0.1).then(|| {
                // Parabolic refinement of the peak between samples.
                let denom = a - 2.0 * b + c;
                let offset = if denom.abs() > 1e-12 {
                    0.5 * (a - c) / denom
                } else {
                    0.0
                };
                (k as f64 + offset) * self.dt
            })
        })
    }

    /// The normalised autocorrelation at a fixed point for every lag from 0 to three quarters of
    /// the rows (NaN where a lag has nothing to compare), each lag's sums over the rows in order
    /// and along each row in cell order. [`LANES`] consecutive lags are summed side by side, read
    /// from a copy of the field laid out cell by cell, where a cell's later rows lie next to each
    /// other; the blocks of lags are dealt out over up to `threads` threads in turn (the short
    /// lags, with the most rows to compare, are the most work). Each lag's sums are its own: the
    /// same answers on any number of threads.
    fn autocorrelations(&self, threads: usize) -> Vec<f64> {
        let lags = self.rows * 3 / 4 + 1;
        // Each cell's rows, then LANES missing ones so that every lane of a block reads inside.
        let stride = self.rows + LANES;
        let mut by_cell = vec![f64::NAN; self.cells * stride];
        for (row, values) in self.field.chunks_exact(self.cells).enumerate() {
            for (i, &v) in values.iter().enumerate() {
                by_cell[i * stride + row] = v;
            }
        }
        let blocks = lags.div_ceil(LANES);
        let threads = threads.clamp(1, blocks.max(1));
        let by_cell = by_cell.as_slice();
        let work = |t: usize| -> Vec<[f64; LANES]> {
            (t..blocks)
                .step_by(threads)
                .map(|b| autocorrelation_block(self, by_cell, stride, b * LANES))
                .collect()
        };
        let dealt = on_threads(threads, work);
        let mut r = Vec::with_capacity(blocks * LANES);
        for b in 0..blocks {
            r.extend_from_slice(&dealt[b % threads][b / threads]);
        }
        r.truncate(lags);
        r
    }
}

/// `work(t)` for each `t` in `0..parts`: `work(0)` on this thread, the others on threads of their
/// own; the answers in `t`'s order.
fn on_threads<T: Send>(parts: usize, work: impl Fn(usize) -> T + Sync) -> Vec<T> {
    if parts < 2 {
        return (0..parts).map(work).collect();
    }
    let work = &work;
    std::thread::scope(|scope| {
        let others: Vec<_> = (1..parts).map(|t| scope.spawn(move || work(t))).collect();
        let mut answers = vec![work(0)];
        for other in others {
            match other.join() {
                Ok(answer) => answers.push(answer),
                Err(panic) => std::panic::resume_unwind(panic),
            }
        }
        answers
    })
}

/// `Σ a·b / √(Σ a² · Σ b²)` from `[Σ a·b, Σ a², Σ b²]`, or `None` where either sum of squares
/// is not positive (nothing to compare).
fn normalised([ab, aa, bb]: [f64; 3]) -> Option<f64> {
    (aa > 0.0 && bb > 0.0).then(|| ab / (aa * bb).sqrt())
}

/// How many lags of the fixed-point autocorrelation are summed side by side in one walk.
const LANES: usize = 8;

/// Adds one lag of the moved-pattern correlation to the sums (`ab`, `aa`, `bb`) of up to
/// [`SPEED_LANES`] trial speeds that move the pattern by `k` whole cells and the share `moved[l]`
/// of the next, exactly as each speed alone would: a cell adds only where it and its
/// interpolated partner are finite. Built twice, for x86-64 and for AVX2 (taken at run time
/// where the CPU has it; the same IEEE operations in the same order, so the same answers to the
/// bit).
#[multiversion(targets("x86_64+avx2"))]
fn add_moved_lag<V: Wide>(grid: &Grid, lag: usize, k: i64, moved: &[f64], sums: &mut [[f64; 3]]) {
    let n = grid.cells;
    // Lanes past the group's speeds: any weights, their sums are dropped.
    let weight = |l: usize| moved.get(l).copied().unwrap_or(0.0);
    let keep = [V::from_fn(|l| 1.0 - weight(l))];
    let moved = [V::from_fn(weight)];
    let mut acc = Lanes::<V, 1>::from_sums(sums);
    // On an open road, the cells `i` whose neighbours `i + k` and `i + k + 1` are both on it; on
    // a loop every cell, its neighbours wrapping round.
    let (from, to) = if grid.closed {
        (0, n)
    } else {
        let from = (-k).clamp(0, n as i64) as usize;
        let to = (n as i64 - 1 - k).clamp(0, n as i64) as usize;
        (from, to)
    };
    if grid.moderate {
        walk_moved_lag::<V, true>(grid, lag, k, (from, to), &keep, &moved, &mut acc);
    } else {
        walk_moved_lag::<V, false>(grid, lag, k, (from, to), &keep, &moved, &mut acc);
    }
    for (s, lane) in sums.iter_mut().zip(acc.sums()) {
        *s = lane;
    }
}

/// The walk of [`add_moved_lag`] over the rows, cells `from..to` of each (see
/// [`Lanes::add_moved`] for `MODERATE`).
#[inline(always)]
fn walk_moved_lag<V: Wide, const MODERATE: bool>(
    grid: &Grid,
    lag: usize,
    k: i64,
    (from, to): (usize, usize),
    keep: &[V; 1],
    moved: &[V; 1],
    acc: &mut Lanes<V, 1>,
) {
    let n = grid.cells;
    for row in 0..grid.rows - lag {
        let here = &grid.field[row * n..(row + 1) * n];
        let there = &grid.field[(row + lag) * n..(row + lag + 1) * n];
        if grid.closed {
            let mut j0 = k.rem_euclid(n as i64) as usize;
            for &a in here {
                let j1 = if j0 + 1 == n { 0 } else { j0 + 1 };
                acc.add_moved::<MODERATE>(a, there[j0], there[j1], keep, moved);
                j0 = j1;
            }
        } else if from < to {
            let j = (from as i64 + k) as usize;
            let len = to - from;
            let pairs = there[j..j + len].iter().zip(&there[j + 1..j + 1 + len]);
            for (&a, (&b0, &b1)) in here[from..to].iter().zip(pairs) {
                acc.add_moved::<MODERATE>(a, b0, b1, keep, moved);
            }
        }
    }
}

/// How many trial speeds sharing a whole-cell shift are summed side by side in one walk.
const SPEED_LANES: usize = 4;

/// A vector of `f64` lanes from `wide`, as the sums use it: its operations round lane by lane as
/// the scalar ones do.
trait Wide:
    Copy
    + std::ops::Add<Output = Self>
    + std::ops::AddAssign
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::BitAnd<Output = Self>
{
    /// Lanes in a vector.
    const WIDTH: usize;
    /// All lanes zero.
    const ZERO: Self;
    /// `x` in every lane.
    fn splat(x: f64) -> Self;
    /// Lane `l` from `f(l)`.
    fn from_fn(f: impl FnMut(usize) -> f64) -> Self;
    /// The lanes from `x`, which holds [`WIDTH`](Self::WIDTH) values.
    fn from_slice(x: &[f64]) -> Self;
    /// Lane `l`.
    fn lane(self, l: usize) -> f64;
    /// All ones in lanes equal to zero, all zeros elsewhere.
    fn is_zero(self) -> Self;
}

macro_rules! wide_lanes {
    ($t:ty, $n:literal) => {
        impl Wide for $t {
            const WIDTH: usize = $n;
            const ZERO: Self = <$t>::ZERO;
            fn splat(x: f64) -> Self {
                <$t>::splat(x)
            }
            fn from_fn(f: impl FnMut(usize) -> f64) -> Self {
                <$t>::new(std::array::from_fn(f))
            }
            fn from_slice(x: &[f64]) -> Self {
                <$t>::new(x.try_into().expect("one value a lane"))
            }
            fn lane(self, l: usize) -> f64 {
                self.to_array()[l]
            }
            fn is_zero(self) -> Self {
                self.simd_eq(<$t>::ZERO)
            }
        }
    };
}
wide_lanes!(f64x2, 2);
wide_lanes!(f64x4, 4);

/// Correlation sums side by side, `M` vectors of lanes: `Σ a·b`, `Σ a²`, `Σ b²`.
struct Lanes<V, const M: usize> {
    ab: [V; M],
    aa: [V; M],
    bb: [V; M],
}

impl<V: Wide, const M: usize> Default for Lanes<V, M> {
    fn default() -> Self {
        Lanes {
            ab: [V::ZERO; M],
            aa: [V::ZERO; M],
            bb: [V::ZERO; M],
        }
    }
}

impl<V: Wide, const M: usize> Lanes<V, M> {
    /// The lanes' sums, one `[Σ a·b, Σ a², Σ b²]` each.
    fn sums(&self) -> impl Iterator<Item = [f64; 3]> + '_ {
        (0..M).flat_map(move |m| {
            (0..V::WIDTH).map(move |l| [self.ab[m].lane(l), self.aa[m].lane(l), self.bb[m].lane(l)])
        })
    }

    /// Lanes holding `sums` in turn (zero past their end).
    fn from_sums(sums: &[[f64; 3]]) -> Self {
        let part = |p: usize| {
            std::array::from_fn(|m| {
                V::from_fn(|l| sums.get(V::WIDTH * m + l).map_or(0.0, |s| s[p]))
            })
        };
        Lanes {
            ab: part(0),
            aa: part(1),
            bb: part(2),
        }
    }

    /// Adds `ab = a·b`, `a2 = a²` and `b²` in each lane where `test` is finite. Adding zero
    /// leaves a sum as it was (none of them is ever −0), so a lane that must skip the cell adds
    /// zero and the lanes stay side by side: each lane's sums are the ones a walk of its own
    /// would make.
    #[expect(
        clippy::eq_op,
        reason = "x - x is zero for a finite x and NaN for any other: a finiteness test"
    )]
    #[inline(always)]
    fn add_where_finite(&mut self, m: usize, test: V, ab: V, a2: V, b: V) {
        let finite = (test - test).is_zero();
        self.ab[m] += ab & finite;
        self.aa[m] += a2 & finite;
        self.bb[m] += (b * b) & finite;
    }

    /// Adds `a` against its partner interpolated between `b0` and `b1` with each lane's weights
    /// (`keep` of `b0`, `moved` of `b1`), in lanes where both are finite.
    ///
    /// With `MODERATE` every value of the field is NaN or at most [`MODERATE_ABS`] across, so no
    /// product or sum of them overflows: a lane's product `a·b` is finite exactly where `a`, `b0`
    /// and `b1` are, and masks the cell without a branch. Otherwise, where `a` or either neighbour
    /// is not finite, neither is any lane's partner, and all skip the cell at once.
    #[inline(always)]
    fn add_moved<const MODERATE: bool>(
        &mut self,
        a: f64,
        b0: f64,
        b1: f64,
        keep: &[V; M],
        moved: &[V; M],
    ) {
        if MODERATE || (a.is_finite() && b0.is_finite() && b1.is_finite()) {
            let (a2, a, b0, b1) = (V::splat(a * a), V::splat(a), V::splat(b0), V::splat(b1));
            for m in 0..M {
                let b = b0 * keep[m] + b1 * moved[m];
                let ab = a * b;
                self.add_where_finite(m, if MODERATE { ab } else { b }, ab, a2, b);
            }
        }
    }

    /// Adds `a` against `partners[WIDTH m + l]` in each lane where both are finite (see
    /// [`add_moved`](Self::add_moved) for `MODERATE`).
    #[inline(always)]
    fn add<const MODERATE: bool>(&mut self, a: f64, partners: &[f64]) {
        if MODERATE || a.is_finite() {
            let (a2, a) = (V::splat(a * a), V::splat(a));
            for m in 0..M {
                let b = V::from_slice(&partners[V::WIDTH * m..V::WIDTH * (m + 1)]);
                let ab = a * b;
                self.add_where_finite(m, if MODERATE { ab } else { b }, ab, a2, b);
            }
        }
    }
}

/// The largest magnitude of a field value for which the sums of the correlations can take the
/// branch-free path: products and sums of a billion of them stay far from overflowing. Speeds
/// in km/h are always this small; a CSV with absurd ones takes the checked path.
const MODERATE_ABS: f64 = 1e100;

/// Whether every value of `field` is NaN or at most [`MODERATE_ABS`] across.
fn moderate(field: &[f64]) -> bool {
    field.iter().all(|v| v.is_nan() || v.abs() <= MODERATE_ABS)
}

/// The fixed-point autocorrelation's sums for the [`LANES`] lags from `first_lag`, normalised:
/// lag `first_lag + l` in lane `l`. `by_cell` is the field cell by cell (`stride` entries a
/// cell, NaN past its last row), so a cell's partners at the block's lags lie side by side; a
/// lane whose partner row is past the last reads NaN there and adds nothing, as if its walk had
/// stopped. Built twice, as [`add_moved_lag`] is.
#[multiversion(targets("x86_64+avx2"))]
fn autocorrelation_block(
    grid: &Grid,
    by_cell: &[f64],
    stride: usize,
    first_lag: usize,
) -> [f64; LANES] {
    let mut acc = Lanes::<f64x4, { LANES / 4 }>::default();
    if grid.moderate {
        walk_lag_block::<true>(grid, by_cell, stride, first_lag, &mut acc);
    } else {
        walk_lag_block::<false>(grid, by_cell, stride, first_lag, &mut acc);
    }
    let mut r = [f64::NAN; LANES];
    for (r, sums) in r.iter_mut().zip(acc.sums()) {
        *r = normalised(sums).unwrap_or(f64::NAN);
    }
    r
}

/// The walk of [`autocorrelation_block`] over the rows and cells (see [`Lanes::add_moved`] for
/// `MODERATE`).
#[inline(always)]
fn walk_lag_block<const MODERATE: bool>(
    grid: &Grid,
    by_cell: &[f64],
    stride: usize,
    first_lag: usize,
    acc: &mut Lanes<f64x4, { LANES / 4 }>,
) {
    let n = grid.cells;
    for row in 0..grid.rows.saturating_sub(first_lag) {
        let here = &grid.field[row * n..(row + 1) * n];
        for (i, &a) in here.iter().enumerate() {
            let start = i * stride + row + first_lag;
            acc.add::<MODERATE>(a, &by_cell[start..start + LANES]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Vehicles on a loop whose speed dips where a jam sits; the jam moves at `c_kmh`.
    fn ring_with_jam(c_kmh: f64, amplitude_kmh: f64) -> Trace {
        let length = 230.0;
        let n = 22;
        let mean = 25.0 / 3.6;
        let mut s: Vec<f64> = (0..n).map(|i| i as f64 * length / n as f64).collect();
        let mut trace = Trace::new();
        let dt = 0.5;
        let speed_at = |x: f64, t: f64| -> f64 {
            let jam = (c_kmh / 3.6 * t).rem_euclid(length);
            let phase = 2.0 * std::f64::consts::PI * (x - jam) / length;
            25.0 - amplitude_kmh * phase.cos()
        };
        for k in 0..400 {
            let t = k as f64 * dt;
            for (id, x) in s.iter_mut().enumerate() {
                let v = speed_at(*x, t);
                trace.push(t, id as u32, "human", "ring", 0, *x, v);
                // Small sub-steps keep the vehicles following the field.
                for _ in 0..10 {
                    *x = (*x + speed_at(*x, t) / 3.6 * dt / 10.0).rem_euclid(length);
                }
            }
        }
        let _ = mean;
        trace
    }

    #[test]
    fn a_backward_moving_jam_is_found_with_its_speed_and_period() {
        let trace = ring_with_jam(-20.0, 10.0);
        let lengths = BTreeMap::from([("ring".to_owned(), 230.0)]);
        let settings = WaveSettings {
            from_s: 50.0,
            ..WaveSettings::default()
        };
        let w = measure_wave(&trace, &lengths, &settings).expect("measured");
        assert!(w.detected, "{w:?}");
        assert!(w.closed);
        let c = w.speed_kmh().expect("speed");
        assert!((c + 20.0).abs() < 1.0, "wave speed {c}");
        // One jam on 230 m passing at 20 km/h: 41.4 s at a fixed point.
        let period = w.period_s().expect("period");
        assert!((period - 41.4).abs() < 2.0, "period {period}");
        assert!(w.amplitude_kmh > 5.0);
    }

    #[test]
    fn loop_length_is_estimated_from_wraps_without_a_summary() {
        let trace = ring_with_jam(-20.0, 10.0);
        let w = measure_wave(&trace, &BTreeMap::new(), &WaveSettings::default()).expect("measured");
        assert!((w.length_m - 230.0).abs() < 0.5, "{}", w.length_m);
        assert!(w.detected);
    }

    #[test]
    fn steady_or_weak_patterns_are_not_waves() {
        let lengths = BTreeMap::from([("ring".to_owned(), 230.0)]);
        // A standing pattern (a bend everyone brakes for) does not travel.
        let standing = measure_wave(
            &ring_with_jam(0.0, 10.0),
            &lengths,
            &WaveSettings::default(),
        )
        .expect("measured");
        assert!(!standing.detected, "{standing:?}");
        assert!(standing.best_speed_kmh.abs() < 1.0);
        // A travelling ripple of 1 km/h at 25 km/h is not stop-and-go.
        let weak = measure_wave(
            &ring_with_jam(-20.0, 1.0),
            &lengths,
            &WaveSettings::default(),
        )
        .expect("measured");
        assert!(!weak.detected, "{weak:?}");
        assert_eq!(weak.speed_kmh(), None);
        assert_eq!(weak.period_s(), None);
    }

    #[test]
    fn no_shared_road_measures_nothing() {
        let mut trace = Trace::new();
        trace.push(0.0, 1, "auto", "a", 0, 1.0, 50.0);
        trace.push(0.5, 1, "auto", "a", 0, 8.0, 50.0);
        assert_eq!(
            measure_wave(&trace, &BTreeMap::new(), &WaveSettings::default()),
            None
        );
    }

    /// Every cell visited in turn, as the correlation was first written: what it must match.
    fn correlation_cell_by_cell(grid: &Grid, c_kmh: f64) -> f64 {
        let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
        for lag_s in LAGS_S {
            let lag = (lag_s / grid.dt).round() as usize;
            if lag == 0 || lag >= grid.rows {
                continue;
            }
            let shift_cells = c_kmh / 3.6 * lag as f64 * grid.dt / grid.cell_m;
            let k = shift_cells.floor();
            let f = shift_cells - k;
            let (k, n) = (k as i64, grid.cells as i64);
            for row in 0..grid.rows - lag {
                let here = &grid.field[row * grid.cells..(row + 1) * grid.cells];
                let there = &grid.field[(row + lag) * grid.cells..(row + lag + 1) * grid.cells];
                for (i, &a) in here.iter().enumerate() {
                    if !a.is_finite() {
                        continue;
                    }
                    let (j0, j1) = (i as i64 + k, i as i64 + k + 1);
                    let (j0, j1) = if grid.closed {
                        (j0.rem_euclid(n), j1.rem_euclid(n))
                    } else if j0 >= 0 && j1 < n {
                        (j0, j1)
                    } else {
                        continue;
                    };
                    let b = there[j0 as usize] * (1.0 - f) + there[j1 as usize] * f;
                    if b.is_finite() {
                        ab += a * b;
                        aa += a * a;
                        bb += b * b;
                    }
                }
            }
        }
        if aa > 0.0 && bb > 0.0 {
            ab / (aa * bb).sqrt()
        } else {
            f64::NEG_INFINITY
        }
    }

    /// Every lag and every cell visited in turn, as the fixed-point autocorrelation was first
    /// written: what it must match.
    fn autocorrelations_lag_by_lag(grid: &Grid) -> Vec<f64> {
        let max_lag = grid.rows * 3 / 4;
        let mut r = Vec::with_capacity(max_lag + 1);
        for lag in 0..=max_lag {
            let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
            for row in 0..grid.rows - lag {
                for i in 0..grid.cells {
                    let a = grid.field[row * grid.cells + i];
                    let b = grid.field[(row + lag) * grid.cells + i];
                    if a.is_finite() && b.is_finite() {
                        ab += a * b;
                        aa += a * a;
                        bb += b * b;
                    }
                }
            }
            r.push(if aa > 0.0 && bb > 0.0 {
                ab / (aa * bb).sqrt()
            } else {
                f64::NAN
            });
        }
        r
    }

    /// A field with gaps: NaN cells here and there and one whole row missing. `absurd` puts
    /// in values no speed has (infinities, and ones whose squares overflow), as a CSV might.
    fn gappy_field(rows: usize, cells: usize, absurd: bool) -> Vec<f64> {
        (0..rows * cells)
            .map(|i| {
                let (row, cell) = (i / cells, i % cells);
                if row == 17 || (i * 7919) % 13 == 0 {
                    f64::NAN
                } else if absurd && i % 11 == 3 {
                    f64::INFINITY
                } else if absurd && i % 7 == 2 {
                    -3e200
                } else {
                    libm::sin(i as f64 * 0.37) * 9.0 + (cell as f64) * 0.1
                }
            })
            .collect()
    }

    /// The fields the fast sums are checked on: moderate ones (the branch-free path), the same
    /// taken down the checked path, and absurd ones (which must take it).
    fn test_fields(rows: usize, cells: usize) -> Vec<(Vec<f64>, bool)> {
        let (usual, absurd) = (
            gappy_field(rows, cells, false),
            gappy_field(rows, cells, true),
        );
        assert!(moderate(&usual));
        assert!(!moderate(&absurd) || rows * cells < 4);
        vec![
            (usual.clone(), true),
            (usual, false),
            (absurd.clone(), moderate(&absurd)),
        ]
    }

    /// The grid of a test field of `rows` rows, cells of 5 m, rows 0.5 s apart.
    fn test_grid(field: &[f64], rows: usize, closed: bool, moderate: bool) -> Grid<'_> {
        Grid {
            field,
            rows,
            cells: field.len() / rows,
            cell_m: 5.0,
            dt: 0.5,
            closed,
            moderate,
        }
    }

    #[test]
    fn the_autocorrelation_is_the_lag_by_lag_walk_s_to_the_bit_on_any_number_of_threads() {
        // Row counts whose lags fill their last block of lanes, and ones that leave it short.
        for (cells, rows) in [(1, 2), (1, 30), (7, 40), (64, 90), (3, 11)] {
            for (field, moderate) in test_fields(rows, cells) {
                let grid = test_grid(&field, rows, false, moderate);
                let walk: Vec<u64> = autocorrelations_lag_by_lag(&grid)
                    .iter()
                    .map(|r| r.to_bits())
                    .collect();
                for threads in [1, 2, 3, 64] {
                    let fast: Vec<u64> = grid
                        .autocorrelations(threads)
                        .iter()
                        .map(|r| r.to_bits())
                        .collect();
                    assert_eq!(
                        fast, walk,
                        "{cells} cells, {rows} rows, moderate {moderate}, {threads} threads"
                    );
                }
            }
        }
    }

    #[test]
    fn the_correlation_is_the_cell_by_cell_walk_s_to_the_bit_on_any_number_of_threads() {
        // A field with gaps (NaN cells and a missing row), on a loop and on an open road, moved
        // at speeds that shift it by less than a cell up to more than the whole road.
        for (cells, rows) in [(1, 30), (7, 40), (64, 90)] {
            for ((field, moderate), closed) in test_fields(rows, cells)
                .into_iter()
                .flat_map(|f| [(f.clone(), false), (f, true)])
            {
                let grid = test_grid(&field, rows, closed, moderate);
                // Coarse steps, and a fine run whose neighbours share their whole-cell shift
                // (summed side by side, more of them than one walk takes).
                let speeds: Vec<f64> = (0..40)
                    .map(|i| -70.0 + 3.3 * f64::from(i))
                    .chain((0..30).map(|i| 12.0 + 0.05 * f64::from(i)))
                    .collect();
                let walk: Vec<u64> = speeds
                    .iter()
                    .map(|&c| correlation_cell_by_cell(&grid, c).to_bits())
                    .collect();
                for threads in [1, 2, 3, 64] {
                    let fast: Vec<u64> = grid
                        .correlations(&speeds, threads)
                        .iter()
                        .map(|r| r.to_bits())
                        .collect();
                    assert_eq!(
                        fast, walk,
                        "{cells} cells, closed {closed}, moderate {moderate}, {threads} threads"
                    );
                }
                let mut c = -300.0;
                while c <= 300.0 {
                    let (fast, walk) = (grid.correlation(c), correlation_cell_by_cell(&grid, c));
                    assert_eq!(
                        fast.to_bits(),
                        walk.to_bits(),
                        "{cells} cells, closed {closed}, moderate {moderate}, {c} km/h: \
                         {fast} against {walk}"
                    );
                    c += 3.7;
                }
            }
        }
    }
}
