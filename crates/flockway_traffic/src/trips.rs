//! Each vehicle's trip (where and when it left and arrived, how far it drove, the time it lost)
//! and how many vehicles came onto each road: what SUMO's tripinfo and edge data record, for
//! comparing a scenario with SUMO. Kept only when a run asks for it (insert a [`TripLog`]).

use bevy_ecs::prelude::*;
use flockway_road::RoadId;
use std::collections::BTreeMap;
use std::sync::Arc;

/// One vehicle's trip, recorded when a destroyer removes it.
#[derive(Debug, Clone, PartialEq)]
pub struct TripRecord {
    /// The vehicle's stable number.
    pub vehicle: u32,
    /// Its driver profile.
    pub profile: Arc<str>,
    /// Its route's name (empty for a vehicle that just followed the road).
    pub route: Arc<str>,
    /// When it was created, s.
    pub depart_s: f64,
    /// The road it was created on.
    pub depart_road: RoadId,
    /// When it was removed, s.
    pub arrival_s: f64,
    /// The road it was removed on.
    pub arrival_road: RoadId,
    /// The distance it drove along the roads, m.
    pub length_m: f64,
    /// Its travel time above the time the same distance takes at the speed limits in force, s
    /// (SUMO's `timeLoss`, against the limits rather than each driver's own desired speed).
    pub time_loss_s: f64,
}

/// How many vehicles a road saw.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RoadCounts {
    /// Vehicles created on it.
    pub departed: u64,
    /// Vehicles that came onto it from another road.
    pub entered: u64,
    /// Vehicles removed on it.
    pub arrived: u64,
}

/// Every finished trip and every road's counts since the start of the run. A run keeps one only
/// when it is inserted as a resource (the spawners and destroyers then fill it).
#[derive(Resource, Debug, Clone, Default, PartialEq)]
pub struct TripLog {
    /// Finished trips, in the order the vehicles arrived (by vehicle id within a tick).
    pub trips: Vec<TripRecord>,
    /// Counts per road; roads no vehicle used are absent.
    pub roads: BTreeMap<RoadId, RoadCounts>,
}

impl TripLog {
    /// Counts a vehicle created on `road`.
    pub fn departed(&mut self, road: RoadId) {
        self.roads.entry(road).or_default().departed += 1;
    }

    /// Counts a vehicle coming onto `road` from another road.
    pub fn entered(&mut self, road: RoadId) {
        self.roads.entry(road).or_default().entered += 1;
    }

    /// Records a finished trip and counts its arrival on its road.
    pub fn arrived(&mut self, trip: TripRecord) {
        self.roads.entry(trip.arrival_road).or_default().arrived += 1;
        self.trips.push(trip);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_follow_departures_entries_and_arrivals() {
        let mut log = TripLog::default();
        log.departed(RoadId(0));
        log.entered(RoadId(1));
        log.entered(RoadId(1));
        log.arrived(TripRecord {
            vehicle: 0,
            profile: "p".into(),
            route: "".into(),
            depart_s: 1.0,
            depart_road: RoadId(0),
            arrival_s: 9.0,
            arrival_road: RoadId(1),
            length_m: 80.0,
            time_loss_s: 2.0,
        });
        assert_eq!(
            log.roads[&RoadId(0)],
            RoadCounts {
                departed: 1,
                entered: 0,
                arrived: 0
            }
        );
        assert_eq!(
            log.roads[&RoadId(1)],
            RoadCounts {
                departed: 0,
                entered: 2,
                arrived: 1
            }
        );
        assert_eq!(log.trips.len(), 1);
    }
}
