//! The safety layer: whatever a driver asks for, the shared controller never lets its car close
//! on a vehicle ahead faster than it can still stop behind it.
//!
//! Every vehicle steered by the shared controller carries a braking envelope
//! ([`SafetyParams`]): the deceleration it plans an emergency stop with, the time it takes to
//! start braking, and the gap it stops at. Each tick, after its driver decided and before the
//! controller turns the target into pedals, its speed is held to what lets it stop behind the
//! nearest vehicle ahead of its body (in its lane, across the lane's link onto the next road,
//! on a junction path sharing its lane, or in a lane either side while either car is partly
//! across), should that vehicle brake as hard as it can plan to itself:
//!
//! `v τ + v² / 2b ≤ gap − s₀ + v_ahead² / 2b`, so
//! `v_safe = −bτ + √(b²τ² + 2b (gap − s₀) + v_ahead²)` (Gipps 1981; Krauß 1998).
//!
//! A model's imperfections (a reaction delay, a wandering speed choice, a harsh throttle) act
//! inside that envelope: a human-like car that reacts late brakes late and hard, it does not
//! drive into the car ahead. Where the car is over the safe speed the controller brakes at
//! least in proportion to the excess, whatever its speed loop's integral remembers.

use crate::perception::{LaneIndex, Seen};
use bevy_ecs::prelude::*;
use flockway_road::RoadNetwork;
use flockway_vehicle::RoadTrack;
use serde::{Deserialize, Serialize};

/// A driver's braking envelope: how it would stop if the vehicle ahead stopped as hard as it
/// can. Every built-in profile has one (`safety.…` in its parameter file).
#[derive(Component, Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SafetyParams {
    /// Time from the vehicle ahead starting to brake to this car braking, s (its reaction time
    /// in an emergency).
    pub reaction_time_s: f32,
    /// Deceleration it plans an emergency stop with, m/s² (and assumes of the vehicle ahead);
    /// below what the car's brakes give on dry asphalt (9.5 m/s² for the sedan), so the car
    /// has brakes to spare for its controller's lag.
    pub decel_mps2: f32,
    /// Bumper gap it stops at behind a stopped vehicle, m.
    pub min_gap_m: f32,
}

impl Default for SafetyParams {
    fn default() -> Self {
        SafetyParams {
            reaction_time_s: 0.3,
            decel_mps2: 6.0,
            min_gap_m: 1.0,
        }
    }
}

impl SafetyParams {
    /// The fastest a car may go, m/s, with bumper gap `gap_m` to a vehicle ahead driving at
    /// `ahead_mps`, to stop behind it with [`Self::min_gap_m`] to spare should that vehicle
    /// brake at [`Self::decel_mps2`] now and this car after [`Self::reaction_time_s`].
    pub fn safe_speed_mps(&self, gap_m: f32, ahead_mps: f32) -> f32 {
        let b = self.decel_mps2.max(0.1);
        let bt = b * self.reaction_time_s.max(0.0);
        let v_ahead = ahead_mps.max(0.0);
        let room = 2.0 * b * (gap_m - self.min_gap_m) + v_ahead * v_ahead;
        if room <= 0.0 {
            return 0.0;
        }
        (-bt + (bt * bt + room).sqrt()).max(0.0)
    }

    /// How far ahead, m (bumper gap), a vehicle can matter to a car at `v`: its stopping
    /// distance and its standstill gap, with a margin.
    pub fn reach_m(&self, v: f32) -> f32 {
        let v = v.max(0.0);
        v * self.reaction_time_s + v * v / (2.0 * self.decel_mps2.max(0.1)) + self.min_gap_m + 10.0
    }

    /// Whether the values make an envelope (positive deceleration, no negative time or gap).
    pub fn validate(&self) -> Result<(), String> {
        if !(self.decel_mps2.is_finite() && self.decel_mps2 > 0.0) {
            return Err(format!(
                "safety.decel_mps2 must be above 0, not {}",
                self.decel_mps2
            ));
        }
        if !(self.reaction_time_s.is_finite() && self.reaction_time_s >= 0.0) {
            return Err(format!(
                "safety.reaction_time_s must be 0 or more, not {}",
                self.reaction_time_s
            ));
        }
        if !(self.min_gap_m.is_finite() && self.min_gap_m >= 0.0) {
            return Err(format!(
                "safety.min_gap_m must be 0 or more, not {}",
                self.min_gap_m
            ));
        }
        Ok(())
    }
}

/// What the safety layer measures a car against: its place, body and speed.
#[derive(Debug, Clone, Copy)]
pub struct SafetyView<'a> {
    /// The car.
    pub me: Entity,
    /// Where it is.
    pub track: &'a RoadTrack,
    /// Its speed along its heading, m/s.
    pub speed_mps: f32,
    /// Its body's length, m.
    pub length_m: f32,
    /// Its body's width, m.
    pub width_m: f32,
    /// The lane change it shows ([`LaneSignal`](crate::LaneSignal)): ±2 while it moves
    /// across into the lane left (+) or right (−) of the one under it.
    pub signal: i8,
}

impl<'a> SafetyView<'a> {
    /// The view of vehicle `me`: where it is, how it moves, its body, and the lane change it
    /// shows (none without a [`LaneSignal`](crate::LaneSignal)).
    pub fn new(
        me: Entity,
        track: &'a RoadTrack,
        motion: &flockway_vehicle::Motion,
        model: &flockway_vehicle::VehicleModel,
        signal: Option<&crate::LaneSignal>,
    ) -> SafetyView<'a> {
        let chassis = &model.0.params.chassis;
        SafetyView {
            me,
            track,
            speed_mps: motion.forward_mps,
            length_m: chassis.length_m,
            width_m: chassis.width_m,
            signal: signal.map_or(0, |s| s.0),
        }
    }
}

/// How far apart sideways two cars' centres may be and still overlap, beyond the sum of their
/// half widths (both taken as this car's width), m: a little room for their bodies' yaw.
const LATERAL_MARGIN_M: f32 = 0.3;

/// A vehicle ahead of a car's body.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ahead {
    /// The vehicle.
    pub entity: Entity,
    /// Bumper-to-bumper gap, m.
    pub gap_m: f32,
    /// Its speed along the road, m/s.
    pub speed_mps: f32,
}

/// The nearest vehicle ahead of the car's body within its reach: the leader in the lane under
/// it (across links onto its next road, and on a junction path sharing its lane), the leader in
/// the lane it is moving into, and any vehicle on this road in a lane either side whose body
/// overlaps its own sideways (one of the two partly across) or that, wholly ahead, is moving
/// across into its lane.
pub fn nearest_ahead(
    network: &RoadNetwork,
    index: &LaneIndex,
    view: &SafetyView,
    reach_m: f32,
) -> Option<Ahead> {
    search(network, index, view, search_range(view, reach_m))
        .best
        .map(|(a, _)| a)
}

/// The centre-to-centre distance within which [`nearest_ahead`] counts a vehicle for a reach
/// (bumper gap) of `reach_m`, m: the reach, this car's length and a margin for the other's.
fn search_range(view: &SafetyView, reach_m: f32) -> f64 {
    f64::from(reach_m + view.length_m + 6.0)
}

/// What one search for the vehicle ahead found.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Found {
    /// The nearest vehicle ahead of the body, with its centre distance, m.
    best: Option<(Ahead, f64)>,
    /// The smallest centre distance of any vehicle the search counted (`INFINITY` for none), m.
    nearest_m: f64,
    /// Whether a window on a closed road went round the whole loop (then its gaps are measured
    /// another way, and the search cannot be narrowed to a shorter range).
    whole_loop: bool,
}

/// [`nearest_ahead`] within `range` m (centre to centre), with what a shorter range needs to
/// be answered from it ([`AheadMemo::answer`]).
fn search(network: &RoadNetwork, index: &LaneIndex, view: &SafetyView, range: f64) -> Found {
    let t = view.track;
    let ahead_of = |s: &Seen| Ahead {
        entity: s.entry.entity,
        gap_m: s.gap_m as f32 - 0.5 * (view.length_m + s.entry.length_m),
        speed_mps: s.entry.speed_mps,
    };
    let mut found = Found {
        best: None,
        nearest_m: f64::INFINITY,
        whole_loop: false,
    };
    // Every vehicle counted, in order: the first with the smallest bumper gap is the answer.
    let count = |found: &mut Found, s: &Seen| {
        let candidate = ahead_of(s);
        found.nearest_m = found.nearest_m.min(s.gap_m);
        if found.best.is_none_or(|(b, _)| candidate.gap_m < b.gap_m) {
            found.best = Some((candidate, s.gap_m));
        }
    };
    if let Some(l) = index.leader(t.road, t.lane, t.s_m, view.me, range, t.next_road) {
        count(&mut found, &l);
    }
    // Moving across: the lane it enters is its own already, whatever the sideways overlap.
    let entering = match view.signal {
        2 => Some(i64::from(t.lane) + 1),
        -2 => Some(i64::from(t.lane) - 1),
        _ => None,
    };
    if let Some(lane) = entering.and_then(|l| u32::try_from(l).ok())
        && let Some(l) = index.leader(t.road, lane, t.s_m, view.me, range, t.next_road)
    {
        count(&mut found, &l);
    }
    let Some(geometry) = network.get(t.road) else {
        return found;
    };
    let lanes = geometry.lanes();
    if lanes < 2 {
        return found;
    }
    // Lateral positions compare only on this road: a car beyond its end is the leader's to see.
    let left_on_road = if geometry.is_closed() {
        f64::INFINITY
    } else {
        geometry.length_m() - t.s_m
    };
    let ahead = range.min(left_on_road);
    // Half the loop, not all of it: flagged whenever the lane index's window could have taken
    // the whole loop, whatever rounding its length carries.
    found.whole_loop = geometry.is_closed() && ahead >= 0.5 * geometry.length_m();
    // The signal of a car in `lane` beside this one moving across into this car's lane: left
    // (+2) from the lane to its right, right (−2) from the lane to its left.
    let into_mine = |lane: u32| if lane < t.lane { 2 } else { -2 };
    let overlap = view.width_m + LATERAL_MARGIN_M;
    // Few of the cars beside overlap this one sideways: each is judged as the index walks it. A
    // car wholly ahead moving across into this car's lane counts however far aside it still
    // is: it is pulling out in front of it (and may have judged its gap before this car sped
    // up). One still alongside is not: it is for that car to wait (braking to let it in would
    // be an emergency stop for every car that moves over beside another).
    let pulling_out = |s: &Seen| s.entry.signal == into_mine(s.lane) && ahead_of(s).gap_m > 0.0;
    let mut beside = |s: Seen| {
        let aside = (s.entry.lateral_m - t.lateral_m as f32).abs() >= overlap;
        if s.gap_m <= 0.0 || (aside && !pulling_out(&s)) {
            return;
        }
        count(&mut found, &s);
    };
    // A lane whose every car is that far aside, none moving across into this one, has none to
    // count: its walk is skipped.
    let me_lateral = t.lateral_m as f32;
    let apart = |lane: u32| {
        index.window_apart(t.road, lane, t.s_m, 0.0, ahead, me_lateral, overlap)
            && !index.any_crossing(t.road, lane, into_mine(lane))
    };
    if t.lane > 0 && !apart(t.lane - 1) {
        let right = t.lane - 1;
        index.visit_within(t.road, right, t.s_m, 0.0, ahead, Some(view.me), &mut beside);
    }
    if t.lane + 1 < lanes && !apart(t.lane + 1) {
        let left = t.lane + 1;
        index.visit_within(t.road, left, t.s_m, 0.0, ahead, Some(view.me), &mut beside);
    }
    found
}

/// How far inside a range a centre distance must be for a narrower search's answer to be read
/// off a wider one, m: far more than the rounding of an arc position, far less than a car.
const NARROW_MARGIN_M: f64 = 1.0e-6;

/// Everything [`nearest_ahead`] reads of a car, to tell the same question asked twice.
#[derive(Debug, Clone, Copy, PartialEq)]
struct ViewKey {
    road: flockway_road::RoadId,
    lane: u32,
    s_m: f64,
    lateral_m: f64,
    next_road: Option<flockway_road::RoadId>,
    speed_mps: f32,
    length_m: f32,
    width_m: f32,
    signal: i8,
}

impl ViewKey {
    fn of(view: &SafetyView) -> ViewKey {
        let t = view.track;
        ViewKey {
            road: t.road,
            lane: t.lane,
            s_m: t.s_m,
            lateral_m: t.lateral_m,
            next_road: t.next_road,
            speed_mps: view.speed_mps,
            length_m: view.length_m,
            width_m: view.width_m,
            signal: view.signal,
        }
    }
}

/// A car's last search for the vehicle ahead of its body, kept so that a second search in the
/// same tick (the safety layer's after the conflict measures') with the same view and a reach
/// no farther is read off it instead of made again: with a shorter range the answer is the same
/// vehicle when it lies well inside that range, none when every vehicle counted lies well
/// beyond it, and otherwise the search runs again — so the answer is always, to the bit, the
/// one [`nearest_ahead`] gives.
#[derive(Component, Debug, Clone, Copy, Default, PartialEq)]
pub struct AheadMemo {
    /// The tick it was made in and the view it was made for.
    made: Option<(flockway_core::Tick, ViewKey)>,
    /// Its range, centre to centre, m.
    range_m: f64,
    /// What it found.
    found: Option<Found>,
}

impl AheadMemo {
    /// [`nearest_ahead`] for `view` with reach `reach_m`, kept as made in tick `tick`.
    pub fn search(
        &mut self,
        network: &RoadNetwork,
        index: &LaneIndex,
        view: &SafetyView,
        reach_m: f32,
        tick: flockway_core::Tick,
    ) -> Option<Ahead> {
        let range_m = search_range(view, reach_m);
        let found = search(network, index, view, range_m);
        *self = AheadMemo {
            made: Some((tick, ViewKey::of(view))),
            range_m,
            found: Some(found),
        };
        found.best.map(|(a, _)| a)
    }

    /// [`nearest_ahead`]'s answer for `view` with reach `reach_m` in tick `tick`, if this memo
    /// gives it for certain (made in that tick for the same view, with a range no shorter);
    /// `None` if the search has to run.
    pub fn answer(
        &self,
        view: &SafetyView,
        reach_m: f32,
        tick: flockway_core::Tick,
    ) -> Option<Option<Ahead>> {
        if self.made != Some((tick, ViewKey::of(view))) {
            return None;
        }
        self.narrowed(view, reach_m)
    }

    /// [`answer`](Self::answer) for the view this memo was just made for (by its caller, in
    /// the same tick): the same without checking that the view and tick are the same.
    pub fn narrowed(&self, view: &SafetyView, reach_m: f32) -> Option<Option<Ahead>> {
        let found = self.found?;
        let range_m = search_range(view, reach_m);
        if range_m == self.range_m {
            return Some(found.best.map(|(a, _)| a));
        }
        if range_m > self.range_m || found.whole_loop {
            return None;
        }
        match found.best {
            Some((a, centre_m)) if centre_m <= range_m - NARROW_MARGIN_M => Some(Some(a)),
            _ if found.nearest_m > range_m + NARROW_MARGIN_M => Some(None),
            _ => None,
        }
    }
}

/// [`nearest_ahead`], read off `memo` where it gives the answer (see [`AheadMemo`]).
pub fn nearest_ahead_memo(
    network: &RoadNetwork,
    index: &LaneIndex,
    view: &SafetyView,
    reach_m: f32,
    memo: Option<(&AheadMemo, flockway_core::Tick)>,
) -> Option<Ahead> {
    match memo.and_then(|(m, tick)| m.answer(view, reach_m, tick)) {
        Some(answer) => answer,
        None => nearest_ahead(network, index, view, reach_m),
    }
}

/// The fastest the car in `view` may go now, m/s: [`SafetyParams::safe_speed_mps`] behind the
/// nearest vehicle ahead of its body ([`nearest_ahead`], read off `memo` where it gives the
/// answer); `INFINITY` with nothing within reach.
pub fn safe_speed_mps(
    network: &RoadNetwork,
    index: &LaneIndex,
    params: &SafetyParams,
    view: &SafetyView,
    memo: Option<(&AheadMemo, flockway_core::Tick)>,
) -> f32 {
    let reach = params.reach_m(view.speed_mps);
    nearest_ahead_memo(network, index, view, reach, memo).map_or(f32::INFINITY, |a| {
        params.safe_speed_mps(a.gap_m, a.speed_mps)
    })
}

/// Braking the controller applies at least, as a share of full braking, per m/s a car is over
/// its safe speed.
pub const OVER_SAFE_BRAKE_PER_MPS: f32 = 0.5;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::perception::fixtures::Lcg;
    use flockway_core::Tick;
    use flockway_road::{RoadId, RoadSpec};
    use glam::DVec3;

    /// A memo made with a wider reach answers a narrower one exactly as a fresh search does,
    /// whenever it answers at all, and it answers most of the time: cars of mixed lengths (so
    /// the nearest centre is not always the nearest bumper), anywhere across their lanes,
    /// some moving across, on a short ring (where a wide window takes the whole loop) and on a
    /// road leading onto another.
    #[test]
    fn a_memo_answers_a_shorter_reach_as_a_search_does() {
        let ring = vec![RoadSpec::ring("ring", 3, 50.0, DVec3::ZERO, 40.0, 12)];
        let mut a = RoadSpec::through("a", 3, 50.0, &[DVec3::ZERO, DVec3::new(300.0, 0.0, 0.0)]);
        a.next = Some("b".into());
        let b = RoadSpec::through(
            "b",
            3,
            50.0,
            &[DVec3::new(300.0, 0.0, 0.0), DVec3::new(500.0, 0.0, 0.0)],
        );
        let (mut answered, mut asked) = (0usize, 0usize);
        for (specs, seed) in [
            (ring, 1u64),
            (vec![a.clone(), b.clone()], 2),
            (vec![a, b], 3),
        ] {
            let network = RoadNetwork::build(&specs).expect("valid roads");
            let mut rng = Lcg(seed);
            let mut world = World::new();
            let cars: Vec<(Entity, RoadTrack, f32, i8)> = (0..120)
                .map(|_| {
                    let road = RoadId(u32::from(specs.len() > 1 && rng.next() < 0.3));
                    let g = network.get(road).expect("road");
                    let s = rng.next() * g.length_m();
                    let half = 0.5 * g.frame_at(s).width_m;
                    let lateral = (rng.next() * 2.0 - 1.0) * (half - 0.3);
                    let mut track = RoadTrack::new(road, g, s, lateral);
                    track.speed_along_mps = (rng.next() * 30.0) as f32;
                    let length = [4.6f32, 4.6, 7.5, 12.0][(rng.next() * 4.0) as usize];
                    let signal = [0i8, 0, 2, -2, 1][(rng.next() * 5.0) as usize];
                    (world.spawn_empty().id(), track, length, signal)
                })
                .collect();
            let mut index = LaneIndex::default();
            index.rebuild(&network, cars.iter().map(|(e, t, l, s)| (*e, t, *l, *s)));
            for (me, track, length, signal) in &cars {
                let view = SafetyView {
                    me: *me,
                    track,
                    speed_mps: track.speed_along_mps,
                    length_m: *length,
                    width_m: 1.8,
                    signal: *signal,
                };
                for wide in [10.0f32, 40.0, 90.0, 250.0] {
                    let mut memo = AheadMemo::default();
                    let tick = Tick(7);
                    let got = memo.search(&network, &index, &view, wide, tick);
                    assert_eq!(got, nearest_ahead(&network, &index, &view, wide));
                    for narrow in [0.0f32, 5.0, 10.0, 25.0, 40.0, 60.0, 90.0, 250.0] {
                        let fresh = nearest_ahead(&network, &index, &view, narrow);
                        let read = memo.answer(&view, narrow, tick);
                        asked += usize::from(narrow <= wide);
                        if let Some(read) = read {
                            answered += 1;
                            assert_eq!(read, fresh, "reach {narrow} read off {wide}");
                            assert!(narrow <= wide);
                        }
                    }
                    // Another tick or another view: no answer.
                    assert_eq!(memo.answer(&view, wide, Tick(8)), None);
                    let moved = SafetyView {
                        speed_mps: view.speed_mps + 1.0,
                        ..view
                    };
                    assert_eq!(memo.answer(&moved, wide, tick), None);
                }
            }
        }
        assert!(answered * 5 >= asked * 4, "{answered} of {asked}");
    }

    /// A car in a lane beside, ahead, at its lane's centre (far aside) is the one ahead only
    /// while it moves across into this car's lane: not waiting to, not moving away, not behind,
    /// not alongside.
    #[test]
    fn a_car_moving_across_into_the_lane_counts_however_far_aside() {
        let road = RoadSpec::through("a", 3, 50.0, &[DVec3::ZERO, DVec3::new(400.0, 0.0, 0.0)]);
        let network = RoadNetwork::build(&[road]).expect("valid road");
        let g = network.get(RoadId(0)).expect("road");
        let lane_w = g.frame_at(0.0).width_m / 3.0;
        let mut world = World::new();
        let me = world.spawn_empty().id();
        let other = world.spawn_empty().id();
        let mine = RoadTrack::new(RoadId(0), g, 100.0, 0.0);
        assert_eq!(mine.lane, 1);
        let view = SafetyView {
            me,
            track: &mine,
            speed_mps: 20.0,
            length_m: 4.6,
            width_m: 1.8,
            signal: 0,
        };
        for (lateral, s, signal, counted) in [
            (-lane_w, 130.0, 2i8, true),
            (-lane_w, 103.0, 2, false),
            (-lane_w, 130.0, 0, false),
            (-lane_w, 130.0, 1, false),
            (-lane_w, 130.0, -2, false),
            (-lane_w, 90.0, 2, false),
            (lane_w, 130.0, -2, true),
            (lane_w, 130.0, 2, false),
        ] {
            let theirs = RoadTrack::new(RoadId(0), g, s, lateral);
            let mut index = LaneIndex::default();
            let cars = [(me, &mine, 4.6f32, 0i8), (other, &theirs, 4.6, signal)];
            index.rebuild(&network, cars.into_iter());
            let got = nearest_ahead(&network, &index, &view, 60.0);
            assert_eq!(
                got.map(|a| a.entity),
                counted.then_some(other),
                "at {lateral} m across, {s} m, signal {signal}"
            );
            if counted {
                let a = got.expect("counted");
                assert!((a.gap_m - (30.0 - 4.6)).abs() < 1e-3, "{}", a.gap_m);
            }
        }
    }

    #[test]
    fn the_safe_speed_stops_the_car_behind_a_leader_that_brakes_as_hard() {
        let p = SafetyParams::default();
        // Behind a stopped car at exactly the standstill gap: stop.
        assert_eq!(p.safe_speed_mps(p.min_gap_m, 0.0), 0.0);
        // Whatever the gap and the leader's speed, the car at the safe speed, braking after its
        // reaction time, stops behind where the leader stops.
        for gap in [0.5f32, 1.0, 3.0, 10.0, 40.0, 120.0] {
            for lead in [0.0f32, 5.0, 15.0, 30.0] {
                let v = p.safe_speed_mps(gap, lead);
                let mine = v * p.reaction_time_s + v * v / (2.0 * p.decel_mps2);
                let theirs = lead * lead / (2.0 * p.decel_mps2);
                assert!(
                    mine <= (gap - p.min_gap_m + theirs).max(0.0) + 1e-3,
                    "gap {gap} lead {lead}: v {v} needs {mine}, has {}",
                    gap - p.min_gap_m + theirs
                );
                // And it is the fastest such speed (a little faster would not stop in time).
                if v > 0.0 {
                    let w = v + 0.01;
                    assert!(
                        w * p.reaction_time_s + w * w / (2.0 * p.decel_mps2)
                            > gap - p.min_gap_m + theirs
                    );
                }
            }
        }
        // Following at the same speed, the envelope leaves a gap of s₀ + vτ.
        let v = p.safe_speed_mps(p.min_gap_m + 20.0 * p.reaction_time_s, 20.0);
        assert!((v - 20.0).abs() < 1e-3, "{v}");
        assert!(p.validate().is_ok());
        assert!(
            SafetyParams {
                decel_mps2: 0.0,
                ..p
            }
            .validate()
            .is_err()
        );
    }
}
