//! Where each vehicle is going: its route through the network, kept up to date as it drives,
//! the lanes that lead on along it, and a new path when it misses its way.

use crate::profile::DriverLabel;
use bevy_ecs::prelude::*;
use flockway_road::{RoadId, RoadNetwork};
use flockway_vehicle::RoadTrack;
use std::collections::BTreeMap;
use std::sync::Arc;

/// Distance per lane to cross within which a vehicle starts changing lanes for its route, m
/// (at least; more at speed, see [`LANE_CHANGE_AHEAD_S`]).
pub const LANE_CHANGE_AHEAD_M: f64 = 200.0;
/// Time per lane to cross, at the current speed, within which a vehicle starts changing lanes
/// for its route, s.
pub const LANE_CHANGE_AHEAD_S: f64 = 20.0;
/// How far short of a lane's end a vehicle that could not leave the lane stops, m (front bumper
/// to the end): room to pull out of it from a standstill.
pub const LANE_END_MARGIN_M: f64 = 6.0;

/// The least share of its usual lane-change time gap a driver accepts, close to its lane's end
/// or its exit: half a second behind a car at its own speed, still more than a human's reaction.
pub const LANE_CHANGE_LEAST_GAP: f32 = 0.5;

/// The share of the room for a lane change ahead that a vehicle preparing for it plans to make
/// it in, at the most.
const PREPARE_SHARE: f64 = 0.7;

/// Distance a car at `v` needs to be mostly (0.8) across one lane taking `cross_s` for the whole
/// crossing, m, plus half its length and 0.5 m.
pub(crate) fn crossing_m(v: f32, cross_s: f32, length_m: f32) -> f64 {
    f64::from(0.8 * v.max(0.0) * cross_s + 0.5 * length_m + 0.5)
}

/// The fastest a vehicle of `length_m` may go to move one lane over, taking `cross_s`, within
/// `room_m`: the speed at which [`crossing_m`] is `room_m`.
pub fn crossing_fit_mps(room_m: f64, length_m: f32, cross_s: f32) -> f32 {
    ((room_m - 0.5 * f64::from(length_m) - 0.5) / (0.8 * f64::from(cross_s.max(0.1)))).max(0.0)
        as f32
}

/// A lane change a route asks for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaneAsk {
    /// +1 left, -1 right.
    pub dir: i8,
    /// Metres left in the current lane before it stops leading on along the route.
    pub left_m: f64,
    /// Lanes still to cross.
    pub lanes: u32,
}

impl LaneAsk {
    /// How much of its usual lane-change gap a driver insists on: all of it while more than
    /// [`LANE_CHANGE_AHEAD_M`] per lane still to cross is left, down to
    /// [`LANE_CHANGE_LEAST_GAP`] of it close to the end.
    pub fn urgency(&self) -> f32 {
        let least = f64::from(LANE_CHANGE_LEAST_GAP);
        (self.left_m / (f64::from(self.lanes.max(1)) * LANE_CHANGE_AHEAD_M)).clamp(least, 1.0)
            as f32
    }
}

/// A vehicle's route: the roads it drives, in order, and where it is along them.
#[derive(Component, Debug, Clone)]
pub struct Route {
    /// The route's name (the telemetry's `route` column); empty for a vehicle that just follows
    /// the road.
    pub name: Arc<str>,
    /// The roads, in driving order; the vehicle is on `roads[index]`.
    roads: Arc<[RoadId]>,
    index: usize,
    /// The road it is bound for, if it has a destination (the route's last road).
    destination: Option<RoadId>,
    /// For each lane of the current road, how far from its start the lane leads on along the
    /// route without a lane change, m.
    reach: Vec<f64>,
    /// For each lane of the current road: its length if the lane ends there with no link, while
    /// other lanes have one (it must be left before its end), `INFINITY` otherwise.
    ends: Vec<f64>,
    reach_for: Option<(RoadId, usize)>,
    /// Exits it missed so far.
    pub missed: u32,
}

impl Route {
    /// A route along `roads` (the first is where the vehicle starts), bound for the last one.
    pub fn along(name: Arc<str>, roads: Vec<RoadId>) -> Route {
        let destination = roads.last().copied();
        Route {
            name,
            roads: roads.into(),
            index: 0,
            destination,
            reach: Vec::new(),
            ends: Vec::new(),
            reach_for: None,
            missed: 0,
        }
    }

    /// No route: the vehicle takes whatever link its lane has at each road's end.
    pub fn follow_road(road: RoadId) -> Route {
        Route {
            destination: None,
            ..Route::along(Arc::from(""), vec![road])
        }
    }

    /// The roads still ahead, the current one first.
    pub fn ahead(&self) -> &[RoadId] {
        self.roads.get(self.index..).unwrap_or(&[])
    }

    /// The road after the current one, if the route says.
    pub fn next_road(&self) -> Option<RoadId> {
        self.roads.get(self.index + 1).copied()
    }

    /// The road it is bound for.
    pub fn destination(&self) -> Option<RoadId> {
        self.destination
    }

    /// How far lane `lane` of the current road leads on along the route from the road's start,
    /// m (`INFINITY` when it needs no lane change).
    pub fn reach_m(&self, lane: u32) -> f64 {
        self.reach
            .get(lane as usize)
            .copied()
            .unwrap_or(f64::INFINITY)
    }

    /// Brings the route up to date with the road the vehicle is on. Returns `true` when it has
    /// left its route (a missed exit: it gets the quickest path from here to its destination, or
    /// no route when there is none).
    pub fn update(&mut self, network: &RoadNetwork, road: RoadId) -> bool {
        let mut missed = false;
        if self.roads.get(self.index) != Some(&road) {
            match self.roads[self.index..].iter().position(|r| *r == road) {
                Some(k) => self.index += k,
                None if self.destination.is_some() => {
                    missed = true;
                    self.missed += 1;
                    let path = self
                        .destination
                        .and_then(|d| network.shortest_path(road, d))
                        .unwrap_or_else(|| vec![road]);
                    if path.last() != self.destination.as_ref() {
                        self.destination = None;
                    }
                    self.roads = path.into();
                    self.index = 0;
                }
                None => {
                    self.roads = vec![road].into();
                    self.index = 0;
                }
            }
        }
        if self.reach_for != Some((road, self.index)) {
            self.ends = lanes_that_end(network, road);
            self.reach = if self.roads.len() > self.index + 1 {
                network.lane_reach(&self.roads[self.index..])
            } else {
                self.ends.clone()
            };
            self.reach_for = Some((road, self.index));
        }
        missed
    }

    /// The lane change the route asks for in `lane` at arc position `s_m` and speed `v_mps`;
    /// `None` if the lane leads on far enough or no lane leads further.
    // The test for a lane that leads on inlined into every driver's step, the search not:
    // mostly the lane leads on, and the call to find that out cost more than the test.
    #[inline(always)]
    pub fn lane_change(&self, lane: u32, s_m: f64, v_mps: f32) -> Option<LaneAsk> {
        let here = self.reach_m(lane);
        if here.is_infinite() {
            return None;
        }
        self.lane_change_from(lane, here, s_m, v_mps)
    }

    /// [`lane_change`](Self::lane_change) from a lane that reaches `here` m along the road.
    #[inline(never)]
    fn lane_change_from(&self, lane: u32, here: f64, s_m: f64, v_mps: f32) -> Option<LaneAsk> {
        // The nearest lane that leads further; the nearer side on a tie.
        let target = (0..self.reach.len() as u32)
            .filter(|&l| self.reach_m(l) > here)
            .min_by_key(|&l| (l.abs_diff(lane), l > lane))?;
        let lanes = target.abs_diff(lane);
        let left = here - s_m;
        let start = f64::from(lanes)
            * LANE_CHANGE_AHEAD_M.max(LANE_CHANGE_AHEAD_S * f64::from(v_mps.max(0.0)));
        (left < start).then_some(LaneAsk {
            dir: if target > lane { 1 } else { -1 },
            left_m: left,
            lanes,
        })
    }

    /// The fastest a vehicle in `lane` at `s_m` on the current road (`road_m` long) may go so
    /// that it reaches the next road slow enough to make there the lane change its route needs
    /// (a lane that opens beside it and must be taken soon: an exit lane), braking at
    /// `decel_mps2`; a crossing takes `cross_s` and the vehicle is `length_m` long. `INFINITY`
    /// when the lane leads on, when a lane of this road leads further (the change is made here,
    /// [`Route::lane_change`]), or when the change leaves room enough.
    pub fn prepare_cap_mps(
        &self,
        lane: u32,
        s_m: f64,
        road_m: f64,
        (length_m, cross_s): (f32, f32),
        decel_mps2: f32,
    ) -> f32 {
        let here = self.reach_m(lane);
        if here.is_infinite() || self.reach.iter().any(|&r| r > here) {
            return f32::INFINITY;
        }
        // Room for the change on the roads beyond this one, and the speed it can be made at
        // with a margin for finding a gap and for the braking to settle.
        let room = here - road_m;
        if room <= 0.0 {
            return f32::INFINITY;
        }
        let fit = f64::from(crossing_fit_mps(PREPARE_SHARE * room, length_m, cross_s));
        let to_next = (road_m - s_m).max(0.0);
        (fit * fit + 2.0 * f64::from(decel_mps2) * to_next).sqrt() as f32
    }

    /// Where lane `lane` of the current road ends with no link (from the road's start, m;
    /// `INFINITY` if it leads on somewhere, on the route or not).
    pub fn lane_end_m(&self, lane: u32) -> f64 {
        self.ends
            .get(lane as usize)
            .copied()
            .unwrap_or(f64::INFINITY)
    }

    /// The fastest a vehicle of length `length_m` in `lane` at `s_m` may go to stop before its
    /// lane ends with no link, braking at `decel_mps2` (`INFINITY` if the lane leads on: at a
    /// split a vehicle in the wrong lane goes on along it, and misses its exit).
    pub fn lane_end_cap_mps(&self, lane: u32, s_m: f64, length_m: f32, decel_mps2: f32) -> f32 {
        let left = self.lane_end_m(lane) - s_m - 0.5 * f64::from(length_m) - LANE_END_MARGIN_M;
        if left.is_infinite() {
            return f32::INFINITY;
        }
        (2.0 * f64::from(decel_mps2) * left.max(0.0)).sqrt() as f32
    }
}

/// Per lane of `road`: its length for a lane that ends there with no link while other lanes
/// have one (traffic in it must merge), `INFINITY` otherwise.
fn lanes_that_end(network: &RoadNetwork, road: RoadId) -> Vec<f64> {
    let Some(g) = network.get(road) else {
        return Vec::new();
    };
    let links = network.links(road);
    (0..g.lanes())
        .map(|lane| {
            if links.is_empty() || links.iter().any(|l| l.lane_to(lane).is_some()) {
                f64::INFINITY
            } else {
                g.length_m()
            }
        })
        .collect()
}

/// Exits missed, over the run: vehicles that left their route because they could not get into a
/// lane leading on along it.
#[derive(Resource, Debug, Clone, Default, PartialEq)]
pub struct RouteStats {
    /// Every vehicle.
    pub missed_exits: u64,
    /// Per driver profile.
    pub missed_by_profile: BTreeMap<String, u64>,
}

/// Keeps every vehicle's [`Route`] in step with the road it is on and tells its track which
/// road to take at the end of this one; counts missed exits.
pub fn follow_routes(
    network: Res<RoadNetwork>,
    mut stats: ResMut<RouteStats>,
    mut vehicles: Query<(&mut Route, &mut RoadTrack, Option<&DriverLabel>)>,
) {
    // The query's fold walks its tables directly, and the step inlined into it makes each car's
    // item in registers: fewer instructions a car than the iterator's `next`.
    vehicles.iter_mut().fold(
        (),
        #[inline(always)]
        |(), (mut route, mut track, label)| {
            if network.get(track.road).is_none() {
                return;
            }
            if route.bypass_update(track.road) {
                return;
            }
            if route.update(&network, track.road) {
                stats.missed_exits += 1;
                if let Some(l) = label {
                    *stats
                        .missed_by_profile
                        .entry(l.profile.to_string())
                        .or_default() += 1;
                }
            }
            let next = route.next_road();
            if track.next_road != next {
                track.next_road = next;
            }
        },
    );
}

impl Route {
    /// Whether nothing changed since the last update (the common case: same road, same place
    /// in the route), so the update can be skipped without touching the component.
    fn bypass_update(&self, road: RoadId) -> bool {
        self.reach_for == Some((road, self.index))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use flockway_road::{LinkSpec, RoadSpec};
    use glam::DVec3;

    /// `a` (3 lanes) splits into `r` (lane 0) and `l` (lanes 1, 2).
    fn split() -> RoadNetwork {
        let w = flockway_road::DEFAULT_LANE_WIDTH_M;
        let mut a = RoadSpec::through("a", 3, 100.0, &[DVec3::ZERO, DVec3::new(800.0, 0.0, 0.0)]);
        a.links = vec![
            LinkSpec {
                to: "r".into(),
                lanes: vec![(0, 0)],
            },
            LinkSpec {
                to: "l".into(),
                lanes: vec![(1, 0), (2, 1)],
            },
        ];
        let r = RoadSpec::through(
            "r",
            1,
            80.0,
            &[DVec3::new(800.0, -w, 0.0), DVec3::new(1000.0, -80.0, 0.0)],
        );
        let l = RoadSpec::through(
            "l",
            2,
            100.0,
            &[
                DVec3::new(800.0, 0.5 * w, 0.0),
                DVec3::new(1000.0, 80.0, 0.0),
            ],
        );
        RoadNetwork::build(&[a, r, l]).expect("valid split")
    }

    #[test]
    fn the_route_asks_for_its_lane_in_good_time() {
        let net = split();
        let (a, r, l) = (RoadId(0), RoadId(1), RoadId(2));
        let mut right = Route::along("right".into(), vec![a, r]);
        right.update(&net, a);
        assert_eq!(right.next_road(), Some(r));
        // Far from the split nothing is asked: two lanes to cross at 60 km/h start 667 m (20 s
        // per lane) before it; at 100 km/h, 1 112 m.
        assert_eq!(right.lane_change(2, 100.0, 16.7), None);
        assert!(right.lane_change(2, 100.0, 27.8).is_some());
        let ask = right
            .lane_change(2, 200.0, 16.7)
            .expect("time to move right");
        assert_eq!((ask.dir, ask.lanes), (-1, 2));
        assert!((ask.left_m - 600.0).abs() < 1.0);
        // It insists on its whole gap until 200 m per lane to cross is left, then less.
        assert_eq!(ask.urgency(), 1.0);
        let late = right.lane_change(2, 760.0, 27.8).expect("late");
        assert!((late.urgency() - 0.5).abs() < 1e-6);
        let one = right.lane_change(1, 760.0, 27.8).expect("one lane to go");
        assert_eq!(one.lanes, 1);
        assert!((one.urgency() - 0.5).abs() < 1e-6);
        assert!((right.lane_change(1, 650.0, 27.8).expect("one").urgency() - 0.75).abs() < 1e-3);
        assert_eq!(right.lane_change(0, 700.0, 27.8), None);
        // Bound left: lane 0 must move over, lanes 1 and 2 are fine.
        let mut left_route = Route::along("left".into(), vec![a, l]);
        left_route.update(&net, a);
        assert_eq!(
            left_route.lane_change(0, 700.0, 20.0).map(|c| c.dir),
            Some(1)
        );
        assert_eq!(left_route.lane_change(1, 700.0, 20.0), None);
        // At a split no lane ends: a car in the wrong lane goes on (and misses its exit).
        assert!(
            left_route
                .lane_end_cap_mps(0, 791.7, 4.6, 2.0)
                .is_infinite()
        );
    }

    #[test]
    fn a_car_reaches_an_exit_lane_that_opens_ahead_slow_enough_to_take_it() {
        // `m` (2 lanes, 500 m) goes on as `d` (3 lanes, 100 m: an exit lane opens on the
        // right), whose lane 0 alone leads onto the exit `x`.
        let w = flockway_road::DEFAULT_LANE_WIDTH_M;
        let mut m = RoadSpec::through("m", 2, 120.0, &[DVec3::ZERO, DVec3::new(500.0, 0.0, 0.0)]);
        m.links = vec![LinkSpec {
            to: "d".into(),
            lanes: vec![(0, 1), (1, 2)],
        }];
        let mut d = RoadSpec::through(
            "d",
            3,
            120.0,
            &[
                DVec3::new(500.0, -0.5 * w, 0.0),
                DVec3::new(600.0, -0.5 * w, 0.0),
            ],
        );
        d.links = vec![LinkSpec {
            to: "x".into(),
            lanes: vec![(0, 0)],
        }];
        let x = RoadSpec::through(
            "x",
            1,
            80.0,
            &[
                DVec3::new(600.0, -1.5 * w, 0.0),
                DVec3::new(800.0, -80.0, 0.0),
            ],
        );
        let net = RoadNetwork::build(&[m, d, x]).expect("valid exit");
        let (mr, dr, xr) = (RoadId(0), RoadId(1), RoadId(2));
        let mut route = Route::along(Arc::from("x"), vec![mr, dr, xr]);
        route.update(&net, mr);
        // No lane of `m` leads further: the change is made on `d`, in at most 70 m of its
        // 100 m (4 s to cross: 21 m/s), which the car reaches braking at 2.5 m/s².
        assert_eq!(route.lane_change(0, 400.0, 33.0), None);
        let fit = crossing_fit_mps(70.0, 4.6, 4.0);
        let at_end = route.prepare_cap_mps(0, 500.0, 500.0, (4.6, 4.0), 2.5);
        assert!((at_end - fit).abs() < 1e-3, "{at_end} {fit}");
        let before = route.prepare_cap_mps(0, 300.0, 500.0, (4.6, 4.0), 2.5);
        assert!((before - (fit * fit + 2.0 * 2.5 * 200.0).sqrt()).abs() < 1e-3);
        // On `d` the change is asked for there, and no longer prepared for.
        route.update(&net, dr);
        assert!(route.lane_change(1, 0.0, 20.0).is_some());
        assert_eq!(
            route.prepare_cap_mps(1, 0.0, 100.0, (4.6, 4.0), 2.5),
            f32::INFINITY
        );
        // Bound straight on, nothing to prepare for.
        let mut on = Route::along(Arc::from("d"), vec![mr, dr]);
        on.update(&net, mr);
        assert_eq!(
            on.prepare_cap_mps(0, 300.0, 500.0, (4.6, 4.0), 2.5),
            f32::INFINITY
        );
    }

    #[test]
    fn a_lane_that_ends_is_left_in_time_or_stopped_in() {
        // `a` (2 lanes) leads on from lane 1 only: lane 0 ends.
        let mut a = RoadSpec::through("a", 2, 100.0, &[DVec3::ZERO, DVec3::new(250.0, 0.0, 0.0)]);
        a.links = vec![LinkSpec {
            to: "b".into(),
            lanes: vec![(1, 0)],
        }];
        let b = RoadSpec::through(
            "b",
            1,
            100.0,
            &[DVec3::new(250.0, 1.5, 0.0), DVec3::new(500.0, 1.5, 0.0)],
        );
        let net = RoadNetwork::build(&[a, b]).expect("valid roads");
        for mut route in [
            Route::follow_road(RoadId(0)),
            Route::along("on".into(), vec![RoadId(0), RoadId(1)]),
        ] {
            route.update(&net, RoadId(0));
            assert_eq!(route.lane_change(0, 100.0, 20.0).map(|c| c.dir), Some(1));
            assert_eq!(route.lane_change(1, 100.0, 20.0), None);
            // The cap stops it 6 m short of the end with its front bumper.
            assert!(route.lane_end_cap_mps(0, 241.7, 4.6, 2.0) < 1e-3);
            assert!((route.lane_end_cap_mps(0, 141.7, 4.6, 2.0) - 20.0).abs() < 1e-3);
            assert!(route.lane_end_cap_mps(1, 241.7, 4.6, 2.0).is_infinite());
        }
    }

    #[test]
    fn a_missed_exit_is_counted_and_rerouted_or_dropped() {
        let net = split();
        let (a, r, l) = (RoadId(0), RoadId(1), RoadId(2));
        let mut route = Route::along("right".into(), vec![a, r]);
        assert!(!route.update(&net, a));
        // It ended up on the left branch: no way from there to `r`.
        assert!(route.update(&net, l));
        assert_eq!(route.missed, 1);
        assert_eq!(route.destination(), None);
        assert_eq!(route.ahead(), &[l]);
        // Following its route is no miss.
        let mut route = Route::along("left".into(), vec![a, l]);
        route.update(&net, a);
        assert!(!route.update(&net, l));
        assert_eq!(route.missed, 0);
        // A vehicle without a route never misses.
        let mut free = Route::follow_road(a);
        assert!(!free.update(&net, r));
    }
}
