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

/// The nearest vehicle ahead of the car's body within its reach: the leader in the lane under it (across links onto its next road, and on a
/// junction path sharing its lane), the leader in the lane it is moving into, and any vehicle
/// on this road in a lane either side whose body overlaps its own sideways (one of the two
/// partly across). `scratch` is reused space.
pub fn nearest_ahead(
    network: &RoadNetwork,
    index: &LaneIndex,
    view: &SafetyView,
    reach_m: f32,
    scratch: &mut Vec<Seen>,
) -> Option<Ahead> {
    let t = view.track;
    let ahead_of = |s: &Seen| Ahead {
        entity: s.entry.entity,
        gap_m: s.gap_m as f32 - 0.5 * (view.length_m + s.entry.length_m),
        speed_mps: s.entry.speed_mps,
    };
    let range = f64::from(reach_m + view.length_m + 6.0);
    let mut best = index
        .leader(t.road, t.lane, t.s_m, view.me, range, t.next_road)
        .map(|l| ahead_of(&l));
    // Moving across: the lane it enters is its own already, whatever the sideways overlap.
    let entering = match view.signal {
        2 => Some(i64::from(t.lane) + 1),
        -2 => Some(i64::from(t.lane) - 1),
        _ => None,
    };
    if let Some(lane) = entering.and_then(|l| u32::try_from(l).ok())
        && let Some(l) = index.leader(t.road, lane, t.s_m, view.me, range, t.next_road)
        && best.is_none_or(|b| ahead_of(&l).gap_m < b.gap_m)
    {
        best = Some(ahead_of(&l));
    }
    let Some(geometry) = network.get(t.road) else {
        return best;
    };
    let lanes = geometry.lanes();
    if lanes < 2 {
        return best;
    }
    // Lateral positions compare only on this road: a car beyond its end is the leader's to see.
    let left_on_road = if geometry.is_closed() {
        f64::INFINITY
    } else {
        geometry.length_m() - t.s_m
    };
    scratch.clear();
    let ahead = range.min(left_on_road);
    if t.lane > 0 {
        index.within(
            t.road,
            t.lane - 1,
            t.s_m,
            0.0,
            ahead,
            Some(view.me),
            scratch,
        );
    }
    if t.lane + 1 < lanes {
        index.within(
            t.road,
            t.lane + 1,
            t.s_m,
            0.0,
            ahead,
            Some(view.me),
            scratch,
        );
    }
    let overlap = view.width_m + LATERAL_MARGIN_M;
    for s in scratch.iter() {
        if s.gap_m <= 0.0 || (s.entry.lateral_m - t.lateral_m as f32).abs() >= overlap {
            continue;
        }
        let found = ahead_of(s);
        if best.is_none_or(|b| found.gap_m < b.gap_m) {
            best = Some(found);
        }
    }
    best
}

/// The fastest the car in `view` may go now, m/s: [`SafetyParams::safe_speed_mps`] behind the
/// nearest vehicle ahead of its body ([`nearest_ahead`]); `INFINITY` with nothing within reach.
pub fn safe_speed_mps(
    network: &RoadNetwork,
    index: &LaneIndex,
    params: &SafetyParams,
    view: &SafetyView,
    scratch: &mut Vec<Seen>,
) -> f32 {
    let reach = params.reach_m(view.speed_mps);
    nearest_ahead(network, index, view, reach, scratch).map_or(f32::INFINITY, |a| {
        params.safe_speed_mps(a.gap_m, a.speed_mps)
    })
}

/// Braking the controller applies at least, as a share of full braking, per m/s a car is over
/// its safe speed.
pub const OVER_SAFE_BRAKE_PER_MPS: f32 = 0.5;

#[cfg(test)]
mod tests {
    use super::*;

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
