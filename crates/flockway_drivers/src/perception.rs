//! What drivers see: a per-lane index of vehicles sorted by arc position, rebuilt every tick.

use bevy_ecs::prelude::*;
use flockway_road::{RoadId, RoadNetwork};
use flockway_vehicle::{Motion, RoadTrack, VehicleModel};
use std::collections::BTreeMap;

/// One vehicle in a lane of the index.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaneEntry {
    /// The vehicle.
    pub entity: Entity,
    /// Arc position of its centre of mass, m.
    pub s_m: f64,
    /// Lateral offset from the road centre line, m (positive left).
    pub lateral_m: f32,
    /// Speed along the road direction, m/s.
    pub speed_mps: f32,
    /// Body length, m.
    pub length_m: f32,
}

/// A vehicle seen from another: its entry and the arc distance to it (positive ahead).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Seen {
    /// Arc distance from the observer's centre to this vehicle's centre, m (positive ahead,
    /// along loops and through a connection onto the next road).
    pub gap_m: f64,
    /// Lane it is in.
    pub lane: u32,
    /// The vehicle.
    pub entry: LaneEntry,
}

#[derive(Debug, Clone, Default)]
struct RoadLanes {
    length_m: f64,
    closed: bool,
    next: Option<RoadId>,
    lanes: Vec<Vec<LaneEntry>>,
}

/// Every vehicle on the roads, per road and lane, sorted by arc position (ties by entity), as of
/// the start of this tick. Queries cost O(log n + k) for k vehicles returned.
#[derive(Resource, Debug, Clone, Default)]
pub struct LaneIndex {
    roads: BTreeMap<RoadId, RoadLanes>,
    vehicles: usize,
}

impl LaneIndex {
    /// Rebuilds the index from vehicles' `(entity, track, motion, length)`.
    pub fn rebuild<'a>(
        &mut self,
        network: &RoadNetwork,
        vehicles: impl Iterator<Item = (Entity, &'a RoadTrack, &'a Motion, f32)>,
    ) {
        // Keep the allocations of last tick's lanes.
        for road in self.roads.values_mut() {
            road.lanes.iter_mut().for_each(Vec::clear);
        }
        self.roads.retain(|id, _| network.get(*id).is_some());
        for (id, g) in network.iter() {
            let road = self.roads.entry(id).or_default();
            road.length_m = g.length_m();
            road.closed = g.is_closed();
            road.next = network.next(id);
            road.lanes.resize_with(g.lanes() as usize, Vec::new);
        }
        self.vehicles = 0;
        for (entity, track, motion, length_m) in vehicles {
            if !track.on_road {
                continue;
            }
            let Some(road) = self.roads.get_mut(&track.road) else {
                continue;
            };
            let Some(lane) = road.lanes.get_mut(track.lane as usize) else {
                continue;
            };
            lane.push(LaneEntry {
                entity,
                s_m: track.s_m,
                lateral_m: track.lateral_m as f32,
                speed_mps: motion.linvel.dot(track.tangent),
                length_m,
            });
            self.vehicles += 1;
        }
        for road in self.roads.values_mut() {
            for lane in &mut road.lanes {
                lane.sort_unstable_by(|a, b| a.s_m.total_cmp(&b.s_m).then(a.entity.cmp(&b.entity)));
            }
        }
    }

    /// Number of vehicles indexed.
    pub fn len(&self) -> usize {
        self.vehicles
    }

    /// Whether no vehicle is indexed.
    pub fn is_empty(&self) -> bool {
        self.vehicles == 0
    }

    /// The vehicles of one lane, sorted by arc position.
    pub fn lane(&self, road: RoadId, lane: u32) -> &[LaneEntry] {
        self.roads
            .get(&road)
            .and_then(|r| r.lanes.get(lane as usize))
            .map_or(&[], Vec::as_slice)
    }

    /// Number of lanes of a road in the index.
    pub fn lanes(&self, road: RoadId) -> u32 {
        self.roads.get(&road).map_or(0, |r| r.lanes.len() as u32)
    }

    /// Every vehicle in `lane` whose arc distance from `s_m` lies in `[-behind_m, ahead_m]`,
    /// except `exclude`, appended to `out` in arc order. Wraps around loops. (`out` is the
    /// caller's, so a driver reuses one buffer for every query of a tick.)
    #[expect(clippy::too_many_arguments, reason = "a query's coordinates, each one number")]
    pub fn within(
        &self,
        road: RoadId,
        lane: u32,
        s_m: f64,
        behind_m: f64,
        ahead_m: f64,
        exclude: Option<Entity>,
        out: &mut Vec<Seen>,
    ) {
        let Some(r) = self.roads.get(&road) else {
            return;
        };
        let Some(entries) = r.lanes.get(lane as usize) else {
            return;
        };
        let mut push = |e: &LaneEntry, gap: f64| {
            if Some(e.entity) != exclude {
                out.push(Seen {
                    gap_m: gap,
                    lane,
                    entry: *e,
                });
            }
        };
        let (lo, hi) = (s_m - behind_m, s_m + ahead_m);
        if r.closed && (behind_m + ahead_m) >= r.length_m {
            // The window covers the whole loop: every vehicle once, at its nearest signed gap.
            for e in entries {
                let mut gap = (e.s_m - s_m).rem_euclid(r.length_m);
                if gap > ahead_m {
                    gap -= r.length_m;
                }
                push(e, gap);
            }
            return;
        }
        let range = |from: f64, to: f64| {
            let a = entries.partition_point(|e| e.s_m < from);
            let b = entries.partition_point(|e| e.s_m <= to);
            a..b.max(a)
        };
        if r.closed && lo < 0.0 {
            for e in &entries[range(lo + r.length_m, r.length_m)] {
                push(e, e.s_m - r.length_m - s_m);
            }
        }
        for e in &entries[range(lo.max(0.0), hi.min(r.length_m))] {
            push(e, e.s_m - s_m);
        }
        if r.closed && hi > r.length_m {
            for e in &entries[range(0.0, hi - r.length_m)] {
                push(e, e.s_m + r.length_m - s_m);
            }
        }
        if !r.closed && hi > r.length_m {
            // Traffic continues onto the connected road's start, in the same lane if it has one.
            if let Some(next) = r.next {
                let lanes = self.lanes(next);
                if lanes > 0 {
                    let lane2 = lane.min(lanes - 1);
                    if let Some(r2) = self.roads.get(&next)
                        && let Some(e2) = r2.lanes.get(lane2 as usize)
                    {
                        let end = e2.partition_point(|e| e.s_m <= hi - r.length_m);
                        for e in &e2[..end] {
                            if Some(e.entity) != exclude {
                                out.push(Seen {
                                    gap_m: r.length_m - s_m + e.s_m,
                                    lane: lane2,
                                    entry: *e,
                                });
                            }
                        }
                    }
                }
            }
        }
    }

    /// The nearest vehicle ahead in `lane` within `range_m` (strictly ahead of `s_m`, or level
    /// with it but later in entity order), following loops and connections.
    pub fn leader(
        &self,
        road: RoadId,
        lane: u32,
        s_m: f64,
        me: Entity,
        range_m: f64,
    ) -> Option<Seen> {
        let mut found = Vec::new();
        self.within(road, lane, s_m, 0.0, range_m, Some(me), &mut found);
        found
            .into_iter()
            .filter(|v| v.gap_m > 0.0 || (v.gap_m == 0.0 && v.entry.entity > me))
            .min_by(|a, b| a.gap_m.total_cmp(&b.gap_m).then(a.entry.entity.cmp(&b.entry.entity)))
    }

    /// The nearest vehicle behind in `lane` within `range_m`, following loops.
    pub fn follower(
        &self,
        road: RoadId,
        lane: u32,
        s_m: f64,
        me: Entity,
        range_m: f64,
    ) -> Option<Seen> {
        let mut found = Vec::new();
        self.within(road, lane, s_m, range_m, 0.0, Some(me), &mut found);
        found
            .into_iter()
            .filter(|v| v.gap_m < 0.0 || (v.gap_m == 0.0 && v.entry.entity < me))
            .max_by(|a, b| a.gap_m.total_cmp(&b.gap_m).then(b.entry.entity.cmp(&a.entry.entity)))
    }
}

/// Rebuilds the [`LaneIndex`] from every vehicle's track, once per tick before drivers decide.
pub fn rebuild_lane_index(
    network: Res<RoadNetwork>,
    mut index: ResMut<LaneIndex>,
    vehicles: Query<(Entity, &RoadTrack, &Motion, &VehicleModel)>,
) {
    index.rebuild(
        &network,
        vehicles
            .iter()
            .map(|(e, t, m, model)| (e, t, m, model.0.params.chassis.length_m)),
    );
}
