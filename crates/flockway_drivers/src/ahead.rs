//! Reading the road ahead: the speed each lane allows from its bends and its grip, and how early
//! a driver must slow down for them.
//!
//! For every way of driving (a [`RoadAheadParams`] and a tyre grip) and every lane, the
//! [`RoadAhead`] resource holds a *speed envelope*: per metre of road, the square of the highest
//! speed from which the driver can still take everything ahead — each bend within its comfortable
//! lateral acceleration, slowing at its comfortable deceleration, on slippery stretches within
//! the share of the grip it trusts. It is one backward pass over the road (and on along the road
//! it leads onto), done when the roads or their surfaces change, so a driver's query is one
//! array lookup.

use bevy_ecs::prelude::*;
use flockway_road::{CURVATURE_BIN_M, RoadGeometry, RoadId, RoadNetwork};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Standard gravity, m/s².
const G_MPS2: f32 = 9.81;
/// Radius beyond which a road counts as straight, m (caps the envelope at about 500 km/h).
const STRAIGHT_RADIUS_M: f32 = 10_000.0;

/// How a driver takes the road ahead. Units are in the names.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RoadAheadParams {
    /// Largest lateral acceleration it accepts in a bend, m/s² (2 is a comfortable motorway
    /// driver; 0 turns reading the road ahead off).
    pub lateral_accel_mps2: f32,
    /// Deceleration with which it slows for a bend or a slippery stretch ahead, m/s².
    pub decel_mps2: f32,
    /// Share of the tyres' grip it uses on a slippery stretch, for cornering and for braking
    /// (on dry asphalt the comfort limits are far inside the grip).
    pub grip_share: f32,
    /// It reads the envelope this far ahead at its speed, s: the time its speed control takes
    /// to follow a new target, so it is down to a bend's speed when the bend begins.
    pub preview_s: f32,
}

impl Default for RoadAheadParams {
    fn default() -> Self {
        RoadAheadParams {
            lateral_accel_mps2: 2.0,
            decel_mps2: 1.5,
            grip_share: 0.3,
            preview_s: 1.0,
        }
    }
}

/// A vehicle whose driver reads the road ahead: its way of driving, and which of the
/// [`RoadAhead`] envelopes is its own (assigned in `Sense` the tick it appears).
#[derive(Component, Debug, Clone, Copy, PartialEq)]
pub struct ReadsRoad {
    /// How it takes bends and slippery stretches.
    pub params: RoadAheadParams,
    /// Its tyres' peak friction coefficient on dry asphalt.
    pub grip: f32,
    style: Option<u32>,
}

impl ReadsRoad {
    /// A driver that reads the road with `params` on tyres of peak friction `grip`.
    pub fn new(params: RoadAheadParams, grip: f32) -> ReadsRoad {
        ReadsRoad {
            params,
            grip,
            style: None,
        }
    }

    fn key(&self) -> [u32; 4] {
        let p = &self.params;
        [
            p.lateral_accel_mps2.to_bits(),
            p.decel_mps2.to_bits(),
            p.grip_share.to_bits(),
            self.grip.to_bits(),
        ]
        // (`preview_s` is applied at the query: it does not change the envelope.)
    }
}

/// A stretch of road with a different surface: tyre friction scaled by `friction_scale` (a wet
/// patch, ice), on some lanes or all.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceStretch {
    /// Road.
    pub road: RoadId,
    /// Start, m.
    pub from_m: f64,
    /// End, m (below `from_m` on a loop: it wraps).
    pub to_m: f64,
    /// Lanes it covers; `None` for all.
    pub lanes: Option<Vec<u32>>,
    /// Friction relative to dry asphalt.
    pub friction_scale: f32,
}

impl SurfaceStretch {
    fn covers(&self, road: RoadId, lane: u32, s_m: f64) -> bool {
        let along = if self.from_m <= self.to_m {
            (self.from_m..=self.to_m).contains(&s_m)
        } else {
            s_m >= self.from_m || s_m <= self.to_m
        };
        road == self.road && along && self.lanes.as_ref().is_none_or(|l| l.contains(&lane))
    }
}

/// The road surfaces drivers know of (the traffic crate's friction triggers keep it filled).
#[derive(Resource, Debug, Clone, Default, PartialEq)]
pub struct RoadSurface {
    /// The stretches whose friction differs from dry asphalt.
    pub stretches: Vec<SurfaceStretch>,
}

impl RoadSurface {
    /// Friction relative to dry asphalt at `s_m` in `lane` of `road`.
    pub fn friction(&self, road: RoadId, lane: u32, s_m: f64) -> f32 {
        self.stretches
            .iter()
            .filter(|t| t.covers(road, lane, s_m))
            .map(|t| t.friction_scale)
            .product()
    }
}

/// One lane's envelopes, the square of the allowed speed per bin: one per road the lane leads
/// onto at its end (the first, its default, where it goes without a route), or one alone for a
/// lane that leads nowhere.
type LaneEnvelopes = Vec<(Option<RoadId>, Arc<[f32]>)>;

/// The speed cap, m/s, an envelope gives at `s_m` (wrapped round a loop of `loop_m`).
fn cap_in(env: &[f32], loop_m: Option<f64>, s_m: f64) -> f32 {
    let s_m = loop_m.map_or(s_m, |length| flockway_core::wrap::rem_euclid(s_m, length));
    let bin = ((s_m.max(0.0) / CURVATURE_BIN_M) as usize).min(env.len().saturating_sub(1));
    env.get(bin).map_or(f32::INFINITY, |v2| v2.sqrt())
}

/// One way of driving's envelopes: `[road][lane]`.
type Envelopes = Vec<Vec<LaneEnvelopes>>;

/// The speed envelopes of every way of driving on the road now (see the module docs).
#[derive(Resource, Debug, Default)]
pub struct RoadAhead {
    /// Per road, its length if it is a closed loop (a query past its end wraps).
    loops: Vec<Option<f64>>,
    styles: Vec<ReadsRoad>,
    envelopes: Vec<Envelopes>,
}

impl RoadAhead {
    /// The highest speed, m/s, from which `reads` can take the road ahead of `s_m` in `lane` of
    /// `road`, going on onto `next` at its end (its route's next road; `None`: where the lane
    /// leads without a route); infinite where nothing ahead asks it to slow (or before its
    /// envelope exists).
    pub fn speed_cap_mps(
        &self,
        reads: &ReadsRoad,
        road: RoadId,
        lane: u32,
        s_m: f64,
        next: Option<RoadId>,
    ) -> f32 {
        self.envelope(reads, road, lane, next)
            .map_or(f32::INFINITY, |(env, length)| cap_in(env, length, s_m))
    }

    /// The lower of [`speed_cap_mps`](Self::speed_cap_mps) at `s_m[0]` and at `s_m[1]` of one
    /// lane (the first's answer `min` the second's), the lane's envelope found once.
    pub fn lower_speed_cap_mps(
        &self,
        reads: &ReadsRoad,
        road: RoadId,
        lane: u32,
        s_m: [f64; 2],
        next: Option<RoadId>,
    ) -> f32 {
        self.envelope(reads, road, lane, next)
            .map_or(f32::INFINITY, |(env, length)| {
                cap_in(env, length, s_m[0]).min(cap_in(env, length, s_m[1]))
            })
    }

    /// The envelope `reads` drives `lane` of `road` by towards `next`, with the road's length if
    /// it is a loop.
    fn envelope(
        &self,
        reads: &ReadsRoad,
        road: RoadId,
        lane: u32,
        next: Option<RoadId>,
    ) -> Option<(&[f32], Option<f64>)> {
        let lanes = self
            .envelopes
            .get(reads.style? as usize)?
            .get(road.0 as usize)?;
        let branches = lanes.get(lane as usize).or(lanes.last())?;
        let (_, env) = branches
            .iter()
            .find(|(to, _)| next.is_some() && *to == next)
            .or(branches.first())?;
        let length = match self.loops.get(road.0 as usize) {
            Some(Some(length)) if *length > 0.0 => Some(*length),
            _ => None,
        };
        Some((env, length))
    }

    /// The number of ways of driving it holds envelopes for.
    pub fn styles(&self) -> usize {
        self.styles.len()
    }

    fn set_loops(&mut self, network: &RoadNetwork) {
        self.loops = network
            .iter()
            .map(|(_, g)| g.is_closed().then(|| g.length_m()))
            .collect();
    }

    fn style_of(&mut self, reads: &ReadsRoad, network: &RoadNetwork, surface: &RoadSurface) -> u32 {
        if self.loops.len() != network.len() {
            self.set_loops(network);
        }
        let key = reads.key();
        if let Some(i) = self.styles.iter().position(|s| s.key() == key) {
            return i as u32;
        }
        self.styles.push(*reads);
        self.envelopes.push(envelopes(reads, network, surface));
        (self.styles.len() - 1) as u32
    }
}

/// Keeps [`RoadAhead`] in step: every envelope again when the roads or their surfaces change,
/// and a new way of driving's envelopes the tick a vehicle brings one.
pub fn update_road_ahead(
    network: Res<RoadNetwork>,
    surface: Res<RoadSurface>,
    mut ahead: ResMut<RoadAhead>,
    mut vehicles: Query<&mut ReadsRoad, Added<ReadsRoad>>,
) {
    if network.is_changed() || surface.is_changed() {
        let ahead = &mut *ahead;
        ahead.set_loops(&network);
        ahead.envelopes = ahead
            .styles
            .iter()
            .map(|s| envelopes(s, &network, &surface))
            .collect();
    }
    for mut reads in &mut vehicles {
        let style = ahead.style_of(&reads, &network, &surface);
        reads.style = Some(style);
    }
}

/// Every road's and lane's envelopes for one way of driving, carried back from the lanes each
/// one leads onto (around a loop and along a chain of roads: repeated until nothing changes).
/// Where a lane leads onto several roads, each branch has its own; a road's start is as slow as
/// its slowest branch needs.
fn envelopes(reads: &ReadsRoad, network: &RoadNetwork, surface: &RoadSurface) -> Envelopes {
    let n = network.len();
    // Per road and lane, where it leads: the loop itself, or each link that takes the lane.
    let branches: Vec<Vec<Vec<(RoadId, u32)>>> = network
        .iter()
        .map(|(id, g)| {
            (0..g.lanes())
                .map(|lane| {
                    if g.is_closed() {
                        vec![(id, lane)]
                    } else {
                        network
                            .links(id)
                            .iter()
                            .filter_map(|l| l.lane_to(lane).map(|b| (l.to, b)))
                            .collect()
                    }
                })
                .collect()
        })
        .collect();
    // Per road, lane and branch: the allowed v² where that branch's lane starts.
    let mut tails: Vec<Vec<Vec<f32>>> = branches
        .iter()
        .map(|lanes| {
            lanes
                .iter()
                .map(|b| vec![f32::INFINITY; b.len().max(1)])
                .collect()
        })
        .collect();
    let limits: Vec<Vec<(Vec<f32>, Vec<f32>)>> = network
        .iter()
        .map(|(id, g)| {
            (0..g.lanes())
                .map(|lane| lane_limits(reads, id, g, lane, surface))
                .collect()
        })
        .collect();
    let mut out: Envelopes = vec![Vec::new(); n];
    for _ in 0..=n + 1 {
        for (i, lanes) in limits.iter().enumerate() {
            out[i] = lanes
                .iter()
                .enumerate()
                .map(|(lane, (cap, brake))| {
                    let to = &branches[i][lane];
                    tails[i][lane]
                        .iter()
                        .enumerate()
                        .map(|(k, &tail)| (to.get(k).map(|b| b.0), backward_pass(cap, brake, tail)))
                        .collect()
                })
                .collect();
        }
        let mut changed = false;
        for (i, lanes) in branches.iter().enumerate() {
            for (lane, to) in lanes.iter().enumerate() {
                for (k, &(road, b)) in to.iter().enumerate() {
                    let Some(heads) = out.get(road.0 as usize) else {
                        continue;
                    };
                    // The slowest start of any branch of the lane it leads onto.
                    let head =
                        heads
                            .get(b as usize)
                            .or(heads.last())
                            .map_or(f32::INFINITY, |envs| {
                                envs.iter()
                                    .filter_map(|(_, e)| e.first().copied())
                                    .fold(f32::INFINITY, f32::min)
                            });
                    let tail = &mut tails[i][lane][k];
                    if head != *tail {
                        *tail = head;
                        changed = true;
                    }
                }
            }
        }
        if !changed {
            break;
        }
    }
    out
}

/// One lane's limits per bin: the v² its bends allow, and the deceleration usable there.
fn lane_limits(
    reads: &ReadsRoad,
    road: RoadId,
    g: &RoadGeometry,
    lane: u32,
    surface: &RoadSurface,
) -> (Vec<f32>, Vec<f32>) {
    let p = &reads.params;
    let bins = g.curvature_bins();
    let mut caps = Vec::with_capacity(bins.len());
    let mut brakes = Vec::with_capacity(bins.len());
    for (i, &k) in bins.iter().enumerate() {
        let s = (i as f64 + 0.5) * CURVATURE_BIN_M;
        let grip = p.grip_share * reads.grip * surface.friction(road, lane, s) * G_MPS2;
        let lateral = p.lateral_accel_mps2.min(grip);
        let radius = if k.abs() > 1.0 / STRAIGHT_RADIUS_M {
            // The lane's own radius: inside a bend it turns tighter than the centre line.
            let d = g.lane_offset_m(lane, s) as f32;
            (1.0 / k - d).abs().clamp(1.0, STRAIGHT_RADIUS_M)
        } else {
            STRAIGHT_RADIUS_M
        };
        caps.push(if p.lateral_accel_mps2 > 0.0 {
            lateral * radius
        } else {
            f32::INFINITY
        });
        brakes.push(p.decel_mps2.min(grip).max(0.1));
    }
    (caps, brakes)
}

/// The envelope from the per-bin limits: v²[i] = min(cap[i], v²[i+1] + 2·decel[i]·bin), the
/// speed from which every later limit is reached braking at the usable deceleration; `tail` is
/// what the road beyond the end allows.
fn backward_pass(caps: &[f32], brakes: &[f32], tail: f32) -> Arc<[f32]> {
    let mut env = vec![0.0f32; caps.len()];
    let mut after = tail;
    for i in (0..caps.len()).rev() {
        after = caps[i].min(after + 2.0 * brakes[i] * CURVATURE_BIN_M as f32);
        env[i] = after;
    }
    env.into()
}

#[cfg(test)]
mod tests {
    use super::*;
    use flockway_road::RoadSpec;
    use glam::DVec3;

    /// A 300 m straight into a quarter circle of radius `r` (left), then 300 m straight.
    fn bend(r: f64) -> RoadSpec {
        let mut pts = vec![
            DVec3::ZERO,
            DVec3::new(150.0, 0.0, 0.0),
            DVec3::new(300.0, 0.0, 0.0),
        ];
        for i in 1..=6 {
            let a = std::f64::consts::FRAC_PI_2 * f64::from(i) / 6.0;
            pts.push(DVec3::new(300.0 + r * a.sin(), r * (1.0 - a.cos()), 0.0));
        }
        pts.push(DVec3::new(300.0 + r, r + 150.0, 0.0));
        pts.push(DVec3::new(300.0 + r, r + 300.0, 0.0));
        RoadSpec::through("bend", 2, 250.0, &pts)
    }

    fn envelope_of(
        spec: RoadSpec,
        reads: ReadsRoad,
        surface: &RoadSurface,
    ) -> (RoadAhead, ReadsRoad) {
        let network = RoadNetwork::build(&[spec]).expect("valid");
        let mut ahead = RoadAhead::default();
        let mut reads = reads;
        reads.style = Some(ahead.style_of(&reads, &network, surface));
        (ahead, reads)
    }

    #[test]
    fn the_cap_in_a_bend_is_the_comfortable_lateral_acceleration_and_it_is_braked_for_in_time() {
        let r = 40.0;
        let reads = ReadsRoad::new(RoadAheadParams::default(), 1.0);
        let (ahead, reads) = envelope_of(bend(r), reads, &RoadSurface::default());
        let road = RoadId(0);
        // Mid-bend, in the right lane (1.75 m outside the centre line of a left bend).
        let mid = 300.0 + 0.25 * std::f64::consts::PI * r;
        let v = ahead.speed_cap_mps(&reads, road, 0, mid, None);
        let want = (2.0 * (r + 1.75) as f32).sqrt();
        assert!((v - want).abs() / want < 0.03, "{v} vs {want}");
        // The left lane turns tighter.
        assert!(ahead.speed_cap_mps(&reads, road, 1, mid, None) < v);
        // 100 m before the bend: exactly what braking at 1.5 m/s² from there reaches.
        let before = ahead.speed_cap_mps(&reads, road, 0, 200.0, None);
        let reach = (want * want + 2.0 * 1.5 * 100.0).sqrt();
        assert!((before - reach).abs() / reach < 0.03, "{before} vs {reach}");
        // 300 m before it: 31 m/s (112 km/h); after the last bend, straight-road speeds (over
        // 400 km/h).
        let start = ahead.speed_cap_mps(&reads, road, 0, 0.0, None);
        let reach = (want * want + 2.0 * 1.5 * 300.0).sqrt();
        assert!((start - reach).abs() / reach < 0.03, "{start} vs {reach}");
        let end = ahead.speed_cap_mps(
            &reads,
            road,
            0,
            300.0 + 0.5 * std::f64::consts::PI * r + 250.0,
            None,
        );
        assert!(end > 110.0, "{end}");
    }

    #[test]
    fn a_wet_stretch_lowers_the_cap_to_the_grip_it_trusts() {
        let r = 60.0;
        let reads = ReadsRoad::new(RoadAheadParams::default(), 1.0);
        let dry = envelope_of(bend(r), reads, &RoadSurface::default());
        let wet_surface = RoadSurface {
            stretches: vec![SurfaceStretch {
                road: RoadId(0),
                from_m: 250.0,
                to_m: 500.0,
                lanes: None,
                friction_scale: 0.3,
            }],
        };
        let wet = envelope_of(bend(r), reads, &wet_surface);
        let mid = 300.0 + 0.25 * std::f64::consts::PI * r;
        let (v_dry, v_wet) = (
            dry.0.speed_cap_mps(&dry.1, RoadId(0), 0, mid, None),
            wet.0.speed_cap_mps(&wet.1, RoadId(0), 0, mid, None),
        );
        // A share of 0.3 of a grip of 0.3 × 9.81: 0.88 m/s² of the 2 m/s² it would accept on
        // dry asphalt.
        let ratio = v_wet / v_dry;
        assert!((ratio - (0.8829f32 / 2.0).sqrt()).abs() < 0.01, "{ratio}");
    }

    #[test]
    fn before_a_split_each_branch_has_its_own_envelope_and_the_route_picks_one() {
        // A 300 m approach splitting into a 30 m-radius bend (the first link) and a straight.
        let approach = RoadSpec {
            links: vec![
                flockway_road::LinkSpec::to("bend"),
                flockway_road::LinkSpec::to("straight"),
            ],
            ..RoadSpec::through(
                "approach",
                2,
                250.0,
                &[
                    DVec3::ZERO,
                    DVec3::new(150.0, 0.0, 0.0),
                    DVec3::new(300.0, 0.0, 0.0),
                ],
            )
        };
        let r = 30.0;
        let mut pts = vec![DVec3::new(300.0, 0.0, 0.0)];
        for i in 1..=6 {
            let a = std::f64::consts::FRAC_PI_2 * f64::from(i) / 6.0;
            pts.push(DVec3::new(300.0 + r * a.sin(), r * (1.0 - a.cos()), 0.0));
        }
        let bend = RoadSpec::through("bend", 2, 250.0, &pts);
        let straight = RoadSpec::through(
            "straight",
            2,
            250.0,
            &[DVec3::new(300.0, 0.0, 0.0), DVec3::new(600.0, 0.0, 0.0)],
        );
        let network = RoadNetwork::build(&[approach, bend, straight]).expect("valid");
        let mut ahead = RoadAhead::default();
        let mut reads = ReadsRoad::new(RoadAheadParams::default(), 1.0);
        reads.style = Some(ahead.style_of(&reads, &network, &RoadSurface::default()));
        let (a, b, st) = (RoadId(0), RoadId(1), RoadId(2));
        let near_end = 280.0;
        let to_bend = ahead.speed_cap_mps(&reads, a, 0, near_end, Some(b));
        let to_straight = ahead.speed_cap_mps(&reads, a, 0, near_end, Some(st));
        // Bound for the bend: the bend's speed plus 20 m of braking; for the straight: no limit
        // a car reaches; without a route: the lane's first link, the bend.
        let want = (2.0 * (r + 1.5) as f32 + 2.0 * 1.5 * 20.0).sqrt();
        assert!((to_bend - want).abs() / want < 0.05, "{to_bend} vs {want}");
        assert!(to_straight > 100.0, "{to_straight}");
        assert_eq!(ahead.speed_cap_mps(&reads, a, 0, near_end, None), to_bend);
    }

    #[test]
    fn on_a_ring_the_envelope_is_the_bend_everywhere_and_zero_lateral_accel_turns_it_off() {
        let spec = RoadSpec::ring("ring", 1, 30.0, DVec3::ZERO, 36.6, 12);
        let reads = ReadsRoad::new(RoadAheadParams::default(), 1.0);
        let (ahead, reads) = envelope_of(spec.clone(), reads, &RoadSurface::default());
        for s in [0.0, 50.0, 229.0] {
            let v = ahead.speed_cap_mps(&reads, RoadId(0), 0, s, None);
            assert!((v - (2.0f32 * 36.6).sqrt()).abs() < 0.1, "{s}: {v}");
        }
        let off = ReadsRoad::new(
            RoadAheadParams {
                lateral_accel_mps2: 0.0,
                ..RoadAheadParams::default()
            },
            1.0,
        );
        let (ahead, off) = envelope_of(spec, off, &RoadSurface::default());
        assert_eq!(
            ahead.speed_cap_mps(&off, RoadId(0), 0, 10.0, None),
            f32::INFINITY
        );
    }

    #[test]
    fn the_lower_cap_of_two_places_is_the_two_caps_min_to_the_bit() {
        let reads = ReadsRoad::new(RoadAheadParams::default(), 1.0);
        let (open, open_reads) = envelope_of(bend(40.0), reads, &RoadSurface::default());
        let ring = RoadSpec::ring("ring", 2, 30.0, DVec3::ZERO, 36.6, 12);
        let (ring, ring_reads) = envelope_of(ring, reads, &RoadSurface::default());
        let unread = ReadsRoad::new(RoadAheadParams::default(), 1.0);
        let places = [-30.0, 0.0, 12.5, 180.0, 299.9, 340.0, 2_000.0, f64::NAN];
        for (ahead, reads) in [(&open, &open_reads), (&ring, &ring_reads), (&open, &unread)] {
            // Lane 5 is past the last lane (its envelope is the last lane's); road 7 has none.
            for (road, lane) in [
                (RoadId(0), 0),
                (RoadId(0), 1),
                (RoadId(0), 5),
                (RoadId(7), 0),
            ] {
                for a in places {
                    for b in places {
                        let want = ahead
                            .speed_cap_mps(reads, road, lane, a, None)
                            .min(ahead.speed_cap_mps(reads, road, lane, b, None));
                        let got = ahead.lower_speed_cap_mps(reads, road, lane, [a, b], None);
                        assert_eq!(got.to_bits(), want.to_bits(), "{road:?} {lane} {a} {b}");
                    }
                }
            }
        }
    }
}
