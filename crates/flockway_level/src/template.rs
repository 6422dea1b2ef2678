//! Starting points for new levels: what `flockway new` writes and what the editor opens with.
//!
//! Every template carries the reference vehicle types (`sedan`, `sedan_human`) and two driver
//! profiles (`autonomous`, the lane-keeping flocking car, and `human`), so a spawner placed on
//! a freshly drawn road has something to spawn.

use crate::expect::Expectation;
use crate::schema::{
    DestroyerPlaceSpec, DestroyerSpec, DriverModel, DriverProfileSpec, InitialVehiclesSpec, Level,
    ProfileShare, Range, SpawnerSpec, VehicleTypeSpec,
};
use flockway_road::RoadSpec;
use glam::DVec3;
use std::collections::BTreeMap;
use std::fmt;

/// A kind of new level. The names (`straight`, `ring`, `empty`) are a command-line contract.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Template {
    /// A 500 m two-lane road with a spawner at its start and a destroyer near its end.
    #[default]
    Straight,
    /// 20 cars on a single-lane loop, 628 m round (a 100 m radius: 50 km/h within 2 m/s²).
    Ring,
    /// Vehicle types and driver profiles only: draw the roads yourself.
    Empty,
}

/// Name of the autonomous driver profile every template defines.
pub const AUTONOMOUS_PROFILE: &str = "autonomous";
/// Name of the human-like driver profile every template defines.
pub const HUMAN_PROFILE: &str = "human";

impl Template {
    /// Every template, in the order help texts list them.
    pub const ALL: [Template; 3] = [Template::Straight, Template::Ring, Template::Empty];

    /// The template's name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Template::Straight => "straight",
            Template::Ring => "ring",
            Template::Empty => "empty",
        }
    }

    /// The template with this name.
    pub fn from_name(name: &str) -> Option<Template> {
        Template::ALL.into_iter().find(|t| t.name() == name)
    }

    /// One line saying what the template holds.
    pub fn summary(self) -> &'static str {
        match self {
            Template::Straight => {
                "a 500 m two-lane road at 80 km/h, a spawner (half autonomous, half human-like \
                 cars) and a destroyer near the end"
            }
            Template::Ring => "20 autonomous cars on a single-lane 628 m loop at 50 km/h",
            Template::Empty => "the reference vehicle types and driver profiles, no roads",
        }
    }

    /// The level this template makes, named `name`.
    pub fn level(self, name: &str) -> Level {
        let mut level = Level::new(1, 120.0);
        level.name = name.to_owned();
        level.description = format!("New level from the `{}` template.", self.name());
        level.vehicle_types = reference_vehicle_types();
        level.driver_profiles = reference_profiles();
        match self {
            Template::Straight => {
                let end = DVec3::new(500.0, 0.0, 0.0);
                level.roads.push(RoadSpec::through(
                    "main",
                    2,
                    80.0,
                    &[DVec3::ZERO, 0.5 * end, end],
                ));
                let profiles = mixed_shares(&level);
                level.spawners.push(SpawnerSpec::new(
                    "start",
                    "main",
                    0,
                    5.0,
                    Range { min: 2.0, max: 4.0 },
                    profiles,
                ));
                level.destroyers.push(DestroyerSpec {
                    name: "end".to_owned(),
                    place: DestroyerPlaceSpec::OnRoad {
                        road: "main".to_owned(),
                        s_m: 480.0,
                    },
                    arrivals_only: false,
                });
                level.telemetry.stats_from_s = 30.0;
                level.expect = expectations(&[
                    "vehicles_spawned > 0",
                    "vehicles_destroyed > 0",
                    "collisions == 0",
                ]);
            }
            Template::Ring => {
                level
                    .roads
                    .push(RoadSpec::ring("ring", 1, 50.0, DVec3::ZERO, 100.0, 16));
                level.vehicles.push(InitialVehiclesSpec {
                    road: "ring".to_owned(),
                    lane: 0,
                    count: 20,
                    profile: AUTONOMOUS_PROFILE.to_owned(),
                    from_m: 0.0,
                    to_m: None,
                    speed_kmh: Some(30.0),
                    jitter_m: 0.5,
                });
                level.telemetry.stats_from_s = 30.0;
                level.expect = expectations(&[
                    "vehicles_spawned == 20",
                    "collisions == 0",
                    "mean_speed_kmh > 40",
                ]);
            }
            Template::Empty => level.description.clear(),
        }
        level
    }
}

impl fmt::Display for Template {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The reference sedan and its human-driven variant, from the shipped assets.
pub fn reference_vehicle_types() -> Vec<VehicleTypeSpec> {
    vec![
        VehicleTypeSpec {
            name: "sedan".to_owned(),
            path: "vehicles/sedan.ron".to_owned(),
        },
        VehicleTypeSpec {
            name: "sedan_human".to_owned(),
            path: "vehicles/sedan_human.ron".to_owned(),
        },
    ]
}

/// The `autonomous` (lane-keeping flocking) and `human` (human-like) driver profiles.
pub fn reference_profiles() -> Vec<DriverProfileSpec> {
    vec![
        DriverProfileSpec {
            name: AUTONOMOUS_PROFILE.to_owned(),
            model: DriverModel::FlockLanes,
            vehicle: "sedan".to_owned(),
            params: Some("drivers/flock_lanes.ron".to_owned()),
            set: BTreeMap::new(),
        },
        DriverProfileSpec {
            name: HUMAN_PROFILE.to_owned(),
            model: DriverModel::Human,
            vehicle: "sedan_human".to_owned(),
            params: Some("drivers/human.ron".to_owned()),
            set: BTreeMap::new(),
        },
    ]
}

/// Profile shares for a new spawner: every profile of the level, the human-like ones together
/// weighing as much as the others together (half and half with the template's two profiles).
pub fn mixed_shares(level: &Level) -> Vec<ProfileShare> {
    let human = |p: &&DriverProfileSpec| p.model == DriverModel::Human;
    let humans = level.driver_profiles.iter().filter(human).count();
    let others = level.driver_profiles.len() - humans;
    level
        .driver_profiles
        .iter()
        .map(|p| {
            let weight = match (human(&p), humans, others) {
                (_, 0, n) | (_, n, 0) => 1.0 / n as f64,
                (true, h, _) => 0.5 / h as f64,
                (false, _, o) => 0.5 / o as f64,
            };
            ProfileShare {
                profile: p.name.clone(),
                weight,
            }
        })
        .collect()
}

fn expectations(texts: &[&str]) -> Vec<Expectation> {
    texts
        .iter()
        .filter_map(|t| Expectation::parse(t).ok())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{level_to_string, parse_level, validate};
    use std::path::Path;

    #[test]
    fn every_template_is_a_valid_level_that_survives_a_round_trip() {
        for t in Template::ALL {
            let level = t.level(t.name());
            assert!(validate(&level).is_empty(), "{t}: {:?}", validate(&level));
            let text = level_to_string(&level).expect("serialises");
            let back = parse_level(&text, Path::new("t.ron")).expect("loads");
            assert_eq!(back, level, "{t}");
            assert_eq!(Template::from_name(t.name()), Some(t));
            assert!(level.driver_profiles.len() == 2 && level.vehicle_types.len() == 2);
        }
        assert!(Template::Empty.level("e").roads.is_empty());
        assert_eq!(Template::from_name("circle"), None);
    }

    #[test]
    fn a_new_spawner_mixes_autonomous_and_human_half_and_half() {
        let mut level = Template::Empty.level("e");
        let shares = mixed_shares(&level);
        assert_eq!(shares.len(), 2);
        assert!(shares.iter().all(|s| (s.weight - 0.5).abs() < 1e-12));
        // Two autonomous kinds and one human: the humans still get half.
        let mut extra = level.driver_profiles[0].clone();
        extra.name = "idm".to_owned();
        extra.model = DriverModel::Idm;
        level.driver_profiles.push(extra);
        let shares = mixed_shares(&level);
        let human: f64 = shares
            .iter()
            .filter(|s| s.profile == HUMAN_PROFILE)
            .map(|s| s.weight)
            .sum();
        assert!((human - 0.5).abs() < 1e-12);
        assert!((shares.iter().map(|s| s.weight).sum::<f64>() - 1.0).abs() < 1e-12);
        // Only humans: they share everything.
        level
            .driver_profiles
            .retain(|p| p.model == DriverModel::Human);
        assert_eq!(mixed_shares(&level)[0].weight, 1.0);
        level.driver_profiles.clear();
        assert!(mixed_shares(&level).is_empty());
    }
}
