//! A run driven step by step from outside — the Python package's `Sim`: the vehicles' state as
//! columns, their leaders, commands for the vehicles a controller drives, spawning and removing
//! vehicles, and the summary at any time. Everything is ordered by vehicle id, so the same
//! level, seed and sequence of calls give the same numbers bit for bit.

use crate::assets::{DriverProfiles, VehicleTypes, find_assets_dir};
use crate::runner::{MAX_RUN_SECONDS, RunError, RunOptions, Runner};
use crate::summary::{level_name, measure};
use bevy_ecs::prelude::*;
use flockway_analysis::Summary;
use flockway_core::TICKS_PER_SECOND;
use flockway_drivers::{DriverLabel, External, ExternalCommand, LaneIndex};
use flockway_level::{Level, load_level};
use flockway_road::{RoadId, RoadNetwork, lane_offset};
use flockway_traffic::{VehicleId, spawn_driven};
use flockway_vehicle::{Controls, Motion, RoadTrack, VehicleSpawn};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// How far ahead [`Session::leaders`] looks, m (centre to centre).
pub const LEADER_RANGE_M: f64 = 500.0;

/// A change to a level before it runs: a top-level setting or a driver profile's parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct Override {
    /// `duration_s`, or `PROFILE.PARAMETER` (a driver profile's name, then a parameter of its
    /// model as a profile's `set` names it: `human.reaction_time_s`, `autonomous.throttle.kp`).
    pub key: String,
    /// The value.
    pub value: f64,
}

/// Applies `overrides` to `level`; an unknown key is an error that lists the valid forms.
pub fn apply_overrides(level: &mut Level, overrides: &[Override]) -> Result<(), RunError> {
    for o in overrides {
        if !o.value.is_finite() {
            return Err(RunError::Argument(format!(
                "override `{}` = {}: expected a finite number",
                o.key, o.value
            )));
        }
        if o.key == "duration_s" {
            if !(o.value > 0.0 && o.value <= MAX_RUN_SECONDS) {
                return Err(RunError::Argument(format!(
                    "override `duration_s` = {}: expected more than 0 and at most {MAX_RUN_SECONDS}",
                    o.value
                )));
            }
            level.duration_s = o.value;
            continue;
        }
        let names: Vec<String> = level
            .driver_profiles
            .iter()
            .map(|p| p.name.clone())
            .collect();
        let known = || {
            format!(
                "override `{}`: expected `duration_s` or PROFILE.PARAMETER with PROFILE one of the \
                 level's driver profiles ({})",
                o.key,
                names.join(", ")
            )
        };
        let Some((profile, parameter)) = o.key.split_once('.') else {
            return Err(RunError::Argument(known()));
        };
        let Some(p) = level.driver_profiles.iter_mut().find(|p| p.name == profile) else {
            return Err(RunError::Argument(known()));
        };
        p.set.insert(parameter.to_owned(), o.value);
    }
    Ok(())
}

/// The vehicles at one moment, a column per quantity, in vehicle id order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VehicleColumns {
    /// Stable vehicle number.
    pub id: Vec<u32>,
    /// Road, as an index into [`Session::road_names`].
    pub road: Vec<u32>,
    /// Lane (0 is the rightmost).
    pub lane: Vec<u32>,
    /// Arc position along the road, m.
    pub s_m: Vec<f64>,
    /// Offset from the road's centre line, m (positive left).
    pub lateral_m: Vec<f64>,
    /// Centre of mass, east, m.
    pub x_m: Vec<f64>,
    /// Centre of mass, north, m.
    pub y_m: Vec<f64>,
    /// Centre of mass, up, m.
    pub z_m: Vec<f64>,
    /// Speed along the body's forward axis, m/s.
    pub speed_mps: Vec<f64>,
    /// Its rate of change, m/s².
    pub accel_mps2: Vec<f64>,
    /// Compass angle of the body's forward axis, rad (0 east, counter-clockwise).
    pub heading_rad: Vec<f64>,
    /// Throttle input (−1..1).
    pub throttle: Vec<f64>,
    /// Steering input (−1..1, positive left).
    pub steering: Vec<f64>,
    /// Driver profile, as an index into [`VehicleColumns::profiles`].
    pub profile: Vec<u32>,
    /// Driver model, as an index into [`VehicleColumns::models`].
    pub model: Vec<u32>,
    /// The profile names the `profile` column indexes.
    pub profiles: Vec<String>,
    /// The model names (`FlockLanes`, `Human`, `Custom(NAME)`, …) the `model` column indexes.
    pub models: Vec<String>,
    /// Route, as an index into [`VehicleColumns::routes`].
    pub route: Vec<u32>,
    /// The route names the `route` column indexes (`""`: following the road).
    pub routes: Vec<String>,
    /// The next road of the level its route takes (a junction's inner path skipped), as an
    /// index into [`Session::road_names`]; −1 without one (following the road, or on its
    /// route's last road).
    pub next_road: Vec<i64>,
}

/// Whether `road` is one of the level's roads (not a junction's inner path).
fn network_has_road(world: &World, road: RoadId) -> bool {
    world
        .resource::<RoadNetwork>()
        .junction_path(road)
        .is_none()
}

/// Each asked-for vehicle's leader in its lane (along its route into the next road).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Leaders {
    /// The leader's id, or −1 with none within [`LEADER_RANGE_M`].
    pub id: Vec<i64>,
    /// Bumper-to-bumper gap, m (infinite with no leader).
    pub gap_m: Vec<f64>,
    /// The leader's speed, m/s (NaN with no leader).
    pub speed_mps: Vec<f64>,
}

/// Why a command could not be carried out.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SessionError {
    /// No vehicle has this id (it never existed, or it has left).
    #[error("there is no vehicle {0} (it may have left the level)")]
    NoVehicle(u32),
    /// Arrays of different lengths.
    #[error("{what}: {got} values for {ids} vehicle ids")]
    Length {
        /// What was given.
        what: &'static str,
        /// How many values.
        got: usize,
        /// How many ids.
        ids: usize,
    },
    /// A value out of range.
    #[error("{0}")]
    Value(String),
}

/// A level run step by step from outside.
pub struct Session {
    runner: Runner,
    name: String,
    road_names: Vec<String>,
    duration_s: f64,
    csv: Option<PathBuf>,
    /// The step the lane index was last rebuilt after, for [`Session::leaders`].
    index_tick: Option<u64>,
}

impl Session {
    /// Loads the level at `path` (errors at file:line:col), applies `overrides`, and sets it up
    /// to run with `seed` (the level's without one), streaming its telemetry CSV to `csv` when
    /// given. Custom-model profiles are driven from outside ([`External`]), except those
    /// `drivers` gives a built-in model ([`RunOptions::drivers`]).
    pub fn open(
        path: &Path,
        seed: Option<u64>,
        overrides: &[Override],
        drivers: BTreeMap<String, flockway_drivers::BuiltinModel>,
        csv: Option<PathBuf>,
    ) -> Result<Session, RunError> {
        // The file is checked as it loads (errors at file:line:col); what overrides change
        // is checked as the profiles are built.
        let mut level = load_level(path)?;
        apply_overrides(&mut level, overrides)?;
        let name = level_name(&level, path);
        let options = RunOptions {
            // As long as the caller steps: the level's duration is its own to honour.
            seconds: Some(MAX_RUN_SECONDS),
            seed,
            csv: csv.clone(),
            assets: Some(find_assets_dir(Some(path))),
            external: true,
            drivers,
            ..RunOptions::default()
        };
        let duration_s = level.duration_s;
        let mut runner = Runner::new(level, &name, &options)?;
        // What a controller reads between steps: each vehicle's waiting, each lane's delay.
        runner
            .sim_mut()
            .world_mut()
            .init_resource::<flockway_traffic::WaitingTimes>();
        let mut session = Session {
            runner,
            name,
            road_names: Vec::new(),
            duration_s,
            csv,
            index_tick: None,
        };
        session.refresh_roads();
        Ok(session)
    }

    fn refresh_roads(&mut self) {
        let network = self.runner.sim().world().resource::<RoadNetwork>();
        let mut names: Vec<(RoadId, String)> = network
            .iter()
            .map(|(id, g)| (id, g.name().to_owned()))
            .collect();
        names.sort_by_key(|(id, _)| id.0);
        self.road_names = names.into_iter().map(|(_, n)| n).collect();
    }

    /// The run (its world and level), for tools that look at it: the off-screen renderer.
    pub fn runner(&self) -> &Runner {
        &self.runner
    }

    /// The run, mutably (capturing vehicle poses queries the world).
    pub fn runner_mut(&mut self) -> &mut Runner {
        &mut self.runner
    }

    /// The level's name in reports.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The level's own duration, s (the session runs for as long as it is stepped).
    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    /// Where the telemetry CSV streams, if anywhere.
    pub fn csv(&self) -> Option<&Path> {
        self.csv.as_deref()
    }

    /// Simulated time, s.
    pub fn time_s(&self) -> f64 {
        self.runner.ticks_done() as f64 / f64::from(TICKS_PER_SECOND)
    }

    /// Runs `n` fixed steps of 1/120 s.
    pub fn step(&mut self, n: u64) -> Result<(), RunError> {
        let first = self.runner.ticks_done() == 0;
        let mut left = n;
        while left > 0 {
            let done = self.runner.step(left)?;
            if done == 0 {
                return Err(RunError::Argument(format!(
                    "the session has run its longest, {MAX_RUN_SECONDS} s"
                )));
            }
            left -= done;
        }
        if first {
            // The network is built by the first step.
            self.refresh_roads();
        }
        Ok(())
    }

    /// Vehicle contacts and guardrail hits so far.
    pub fn collisions(&self) -> u64 {
        let stats = self
            .runner
            .sim()
            .world()
            .resource::<flockway_traffic::TrafficStats>();
        stats.collisions_vehicle + stats.collisions_guardrail
    }

    /// The road names, by road index ([`VehicleColumns::road`]).
    pub fn road_names(&self) -> &[String] {
        &self.road_names
    }

    /// Every vehicle now, in id order.
    pub fn vehicles(&mut self) -> VehicleColumns {
        let world = self.runner.sim_mut().world_mut();
        let mut rows: Vec<_> = world
            .query::<(
                &VehicleId,
                &RoadTrack,
                &Motion,
                &Controls,
                Option<&DriverLabel>,
                Option<&flockway_drivers::Route>,
            )>()
            .iter(world)
            .map(|(id, t, m, c, l, r)| {
                let next = r.and_then(|r| {
                    r.ahead()
                        .iter()
                        .skip(1)
                        .find(|&&road| network_has_road(world, road))
                        .copied()
                });
                let route = r.map_or_else(String::new, |r| r.name.to_string());
                (id.0, *t, *m, *c, l.cloned(), route, next)
            })
            .collect();
        rows.sort_by_key(|r| r.0);
        let mut out = VehicleColumns::default();
        let index = |names: &mut Vec<String>, name: &str| -> u32 {
            match names.iter().position(|n| n == name) {
                Some(k) => k as u32,
                None => {
                    names.push(name.to_owned());
                    (names.len() - 1) as u32
                }
            }
        };
        for (id, track, motion, controls, label, route, next) in rows {
            let forward = motion.forward();
            out.id.push(id);
            out.road.push(track.road.0);
            out.lane.push(track.lane);
            out.s_m.push(track.s_m);
            out.lateral_m.push(track.lateral_m);
            out.x_m.push(f64::from(motion.position.x));
            out.y_m.push(f64::from(motion.position.y));
            out.z_m.push(f64::from(motion.position.z));
            out.speed_mps.push(f64::from(motion.forward_mps));
            out.accel_mps2.push(f64::from(motion.accel_mps2));
            out.heading_rad
                .push(libm::atan2(f64::from(forward.y), f64::from(forward.x)));
            out.throttle.push(f64::from(controls.throttle));
            out.steering.push(f64::from(controls.steering));
            let (profile, model) = label.map_or_else(
                || ("none".to_owned(), "none".to_owned()),
                |l| (l.profile.to_string(), l.model.to_string()),
            );
            let p = index(&mut out.profiles, &profile);
            out.profile.push(p);
            let m = index(&mut out.models, &model);
            out.model.push(m);
            let r = index(&mut out.routes, &route);
            out.route.push(r);
            out.next_road
                .push(next.map_or(-1, |road| i64::from(road.0)));
        }
        out
    }

    /// The entity of every vehicle now, by id.
    fn entities(&mut self) -> BTreeMap<u32, Entity> {
        let world = self.runner.sim_mut().world_mut();
        world
            .query::<(Entity, &VehicleId)>()
            .iter(world)
            .map(|(e, id)| (id.0, e))
            .collect()
    }

    /// The entity of vehicle `id`.
    pub(crate) fn entity_of(&mut self, id: u32) -> Result<Entity, SessionError> {
        self.entities_of(&[id]).map(|e| e[0])
    }

    /// The entities of `ids`, in order; the first unknown id is an error.
    fn entities_of(&mut self, ids: &[u32]) -> Result<Vec<Entity>, SessionError> {
        let entities = self.entities();
        ids.iter()
            .map(|id| {
                entities
                    .get(id)
                    .copied()
                    .ok_or(SessionError::NoVehicle(*id))
            })
            .collect()
    }

    /// Each vehicle's leader: the nearest vehicle ahead in its lane, within
    /// [`LEADER_RANGE_M`], as of now (the lane index is rebuilt from the vehicles' positions
    /// after the last step: the index the next step's drivers will see).
    pub fn leaders(&mut self, ids: &[u32]) -> Result<Leaders, SessionError> {
        let tick = self.runner.sim().tick().0;
        if self.index_tick != Some(tick) {
            // The step rebuilds the index from scratch before its drivers decide, so this
            // changes nothing the step computes.
            let world = self.runner.sim_mut().world_mut();
            if world
                .run_system_cached(flockway_drivers::rebuild_lane_index)
                .is_ok()
            {
                self.index_tick = Some(tick);
            }
        }
        let entities = self.entities();
        let ids_of: BTreeMap<Entity, u32> = entities.iter().map(|(id, e)| (*e, *id)).collect();
        let world = self.runner.sim().world();
        let index = world.resource::<LaneIndex>();
        let mut out = Leaders::default();
        for &id in ids {
            let e = *entities.get(&id).ok_or(SessionError::NoVehicle(id))?;
            let (Some(track), Some(model)) = (
                world.get::<RoadTrack>(e),
                world.get::<flockway_vehicle::VehicleModel>(e),
            ) else {
                return Err(SessionError::NoVehicle(id));
            };
            let own = f64::from(model.0.params.chassis.length_m);
            match index.leader(
                track.road,
                track.lane,
                track.s_m,
                e,
                LEADER_RANGE_M,
                track.next_road,
            ) {
                Some(l) => {
                    out.id
                        .push(ids_of.get(&l.entry.entity).map_or(-1, |&i| i64::from(i)));
                    out.gap_m
                        .push(l.gap_m - 0.5 * (own + f64::from(l.entry.length_m)));
                    out.speed_mps.push(f64::from(l.entry.speed_mps));
                }
                None => {
                    out.id.push(-1);
                    out.gap_m.push(f64::INFINITY);
                    out.speed_mps.push(f64::NAN);
                }
            }
        }
        Ok(out)
    }

    /// Gives each vehicle a command that holds until the next: `commands[k]` for `ids[k]`
    /// (`None` hands it back to its own driver). A vehicle of a built-in model is taken over.
    pub fn command(
        &mut self,
        ids: &[u32],
        commands: &[Option<ExternalCommand>],
    ) -> Result<(), SessionError> {
        if ids.len() != commands.len() {
            return Err(SessionError::Length {
                what: "commands",
                got: commands.len(),
                ids: ids.len(),
            });
        }
        // All or nothing: every id and value is checked before any vehicle is told.
        let targets = self.entities_of(ids)?;
        for ((id, e), c) in ids.iter().zip(&targets).zip(commands) {
            match c {
                Some(ExternalCommand::Target { speed_mps, lane }) => {
                    if !(speed_mps.is_finite() && *speed_mps >= 0.0) {
                        return Err(SessionError::Value(format!(
                            "vehicle {id}: target speed {speed_mps} m/s: expected a finite \
                             number, 0 or more"
                        )));
                    }
                    if let Some(lane) = lane {
                        let world = self.runner.sim().world();
                        let network = world.resource::<RoadNetwork>();
                        let road = world.get::<RoadTrack>(*e).and_then(|t| network.get(t.road));
                        if let Some(g) = road
                            && *lane >= g.lanes()
                        {
                            return Err(SessionError::Value(format!(
                                "vehicle {id}: lane {lane}: its road `{}` has {} lane(s), \
                                 numbered from 0 (the rightmost)",
                                g.name(),
                                g.lanes()
                            )));
                        }
                    }
                }
                Some(ExternalCommand::Controls(k)) => {
                    for (what, v) in [("throttle", k.throttle), ("steering", k.steering)] {
                        if !(v.is_finite() && (-1.0..=1.0).contains(&v)) {
                            return Err(SessionError::Value(format!(
                                "vehicle {id}: {what} {v}: expected a number from -1 to 1"
                            )));
                        }
                    }
                }
                None => {}
            }
        }
        let world = self.runner.sim_mut().world_mut();
        for (e, command) in targets.into_iter().zip(commands) {
            let mut entity = world.entity_mut(e);
            match entity.get_mut::<External>() {
                Some(mut x) => x.command = *command,
                None => {
                    if command.is_some() {
                        entity.insert(External {
                            model: Arc::from("external"),
                            command: *command,
                        });
                    }
                }
            }
        }
        Ok(())
    }

    /// Spawns a vehicle of driver profile `profile` on road `road`, `s_m` along it in `lane`,
    /// at `speed_mps`, on the route `heading` asks for (following the road without one);
    /// returns its id.
    pub fn spawn(
        &mut self,
        road: &str,
        s_m: f64,
        lane: u32,
        speed_mps: f32,
        profile: &str,
        heading: Option<&crate::routes::Heading>,
    ) -> Result<u32, SessionError> {
        let Some(p) = self
            .runner
            .level()
            .driver_profiles
            .iter()
            .find(|p| p.name == profile)
            .cloned()
        else {
            let known: Vec<&str> = self
                .runner
                .level()
                .driver_profiles
                .iter()
                .map(|p| p.name.as_str())
                .collect();
            return Err(SessionError::Value(format!(
                "there is no driver profile `{profile}`; the level's are {}",
                known.join(", ")
            )));
        };
        let world = self.runner.sim_mut().world_mut();
        let network = world.resource::<RoadNetwork>();
        let id = network
            .id(road)
            .ok_or_else(|| SessionError::Value(format!("there is no road `{road}`")))?;
        let geometry = network.get(id).expect("an id the network gave");
        if !(s_m.is_finite() && (0.0..=geometry.length_m()).contains(&s_m)) {
            return Err(SessionError::Value(format!(
                "{s_m} m: road `{road}` is {:.1} m long",
                geometry.length_m()
            )));
        }
        if lane >= geometry.lanes() {
            return Err(SessionError::Value(format!(
                "road `{road}` has {} lane(s), not lane {lane}",
                geometry.lanes()
            )));
        }
        if !(speed_mps.is_finite() && speed_mps >= 0.0) {
            return Err(SessionError::Value(format!(
                "speed {speed_mps} m/s: expected 0 or more"
            )));
        }
        let lateral = lane_offset(geometry.frame_at(s_m).width_m, geometry.lanes(), lane);
        let vehicle = world
            .resource::<VehicleTypes>()
            .0
            .get(&p.vehicle)
            .cloned()
            .ok_or_else(|| SessionError::Value(format!("no vehicle type `{}`", p.vehicle)))?;
        let driver = world
            .resource::<DriverProfiles>()
            .0
            .get(profile)
            .cloned()
            .ok_or_else(|| SessionError::Value(format!("profile `{profile}` is not built")))?;
        let route = heading
            .map(|h| crate::routes::route_from(network, id, h))
            .transpose()?;
        let spawn = VehicleSpawn::new(vehicle, id, s_m)
            .lateral(lateral)
            .speed(speed_mps);
        let e = spawn_driven(world, spawn, &driver, lane, Arc::from(profile))
            .map_err(|e| SessionError::Value(e.to_string()))?;
        if let Some(route) = route {
            world.entity_mut(e).insert(route);
        }
        self.index_tick = None;
        Ok(world.get::<VehicleId>(e).map_or(0, |v| v.0))
    }

    /// Removes vehicles (they leave without being counted as destroyed).
    pub fn despawn(&mut self, ids: &[u32]) -> Result<(), SessionError> {
        let targets = self.entities_of(ids)?;
        self.index_tick = None;
        let world = self.runner.sim_mut().world_mut();
        for e in targets {
            world.despawn(e);
        }
        Ok(())
    }

    /// Every induction loop of the level now (empty columns for a level without detectors).
    pub fn detectors(&self) -> crate::DetectorColumns {
        self.runner
            .sim()
            .world()
            .get_resource::<flockway_traffic::Detectors>()
            .map(crate::DetectorColumns::of)
            .unwrap_or_default()
    }

    /// Every detector period closed so far, as the detectors CSV's text (a header only for a
    /// level without detectors); with `current`, each loop's current period so far after them.
    pub fn detector_log(&self, current: bool) -> String {
        let world = self.runner.sim().world();
        let none = flockway_traffic::Detectors::default();
        crate::readings_csv(
            world.resource::<RoadNetwork>(),
            world
                .get_resource::<flockway_traffic::Detectors>()
                .unwrap_or(&none),
            current,
        )
    }

    /// The summary of the run so far, as `flockway run` reports it at its end.
    pub fn summary(&self) -> Summary {
        measure(
            self.runner.sim(),
            self.runner.level(),
            &self.name,
            self.runner.trace(),
            self.runner.stepping(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shipped(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../levels/{name}.ron"))
    }

    fn ring(seed: u64) -> Session {
        Session::open(
            &shipped("sugiyama_ring"),
            Some(seed),
            &[],
            BTreeMap::new(),
            None,
        )
        .expect("opens")
    }

    /// A ring with two custom-model cars among four lane-keeping autonomous ones.
    fn custom_ring(dir: &Path) -> PathBuf {
        let text = std::fs::read_to_string(shipped("sugiyama_ring")).expect("the level");
        let start = text.find("driver_profiles:").expect("profiles");
        let end = start + text[start..].find("telemetry:").expect("telemetry");
        let body = r#"driver_profiles: [
        (name: "auto", model: FlockLanes, vehicle: "sedan"),
        (name: "mine", model: Custom("keeper"), vehicle: "sedan"),
    ],
    vehicles: [
        (road: "ring", count: 4, profile: "auto", from_m: 0.0, to_m: 150.0, speed_kmh: 20.0),
        (road: "ring", count: 2, profile: "mine", from_m: 150.0, to_m: 220.0, speed_kmh: 20.0),
    ],
    "#;
        let level = format!("{}{body}{}", &text[..start], &text[end..]);
        let path = dir.join("custom_ring.ron");
        std::fs::write(&path, level).expect("write");
        path
    }

    #[test]
    fn the_same_seed_and_calls_give_the_same_columns_bit_for_bit() {
        let (mut a, mut b) = (ring(3), ring(3));
        for s in [&mut a, &mut b] {
            s.step(600).expect("steps");
            let ids = s.vehicles().id;
            s.command(
                &ids[..2],
                &[
                    Some(ExternalCommand::Target {
                        speed_mps: 4.0,
                        lane: None,
                    }),
                    None,
                ],
            )
            .expect("commands");
            s.step(240).expect("steps");
        }
        let (va, vb) = (a.vehicles(), b.vehicles());
        assert_eq!(va, vb);
        assert_eq!(va.id.len(), 22);
        assert!(va.id.windows(2).all(|w| w[0] < w[1]), "in id order");
        assert!((a.time_s() - 7.0).abs() < 1e-12);
        assert_eq!(a.road_names(), ["ring"]);
        assert_ne!(ring(4).vehicles(), {
            let mut c = ring(3);
            c.vehicles()
        });
    }

    #[test]
    fn every_car_on_a_ring_has_a_leader_a_positive_gap_ahead() {
        let mut s = ring(1);
        s.step(120).expect("steps");
        let v = s.vehicles();
        let l = s.leaders(&v.id).expect("leaders");
        assert_eq!(l.id.len(), 22);
        for k in 0..22 {
            assert!(l.id[k] >= 0 && l.id[k] != i64::from(v.id[k]));
            assert!(l.gap_m[k] > 0.0 && l.gap_m[k] < 20.0, "{}", l.gap_m[k]);
        }
        assert_eq!(s.leaders(&[999]), Err(SessionError::NoVehicle(999)));
    }

    #[test]
    fn a_target_and_controls_take_a_car_over_and_none_hands_it_back() {
        let mut s = ring(1);
        s.step(120).expect("steps");
        let id = s.vehicles().id[5];
        let speed = |s: &mut Session| {
            let v = s.vehicles();
            let k = v.id.iter().position(|&i| i == id).expect("still there");
            v.speed_mps[k]
        };
        s.command(
            &[id],
            &[Some(ExternalCommand::Target {
                speed_mps: 2.0,
                lane: None,
            })],
        )
        .expect("a target");
        s.step(1200).expect("steps");
        assert!((speed(&mut s) - 2.0).abs() < 0.3, "{}", speed(&mut s));
        // Off the throttle, handbrake on: it stops (a negative throttle would brake, then
        // reverse from a standstill).
        s.command(
            &[id],
            &[Some(ExternalCommand::Controls(Controls {
                throttle: 0.0,
                steering: 0.0,
                handbrake: true,
            }))],
        )
        .expect("controls");
        s.step(360).expect("steps");
        assert!(speed(&mut s).abs() < 0.1, "{}", speed(&mut s));
        let v = s.vehicles();
        let k = v.id.iter().position(|&i| i == id).expect("there");
        assert_eq!(v.throttle[k], 0.0);
        // Handed back, it drives off with the others.
        s.command(&[id], &[None]).expect("back");
        let mut fastest = 0.0f64;
        for _ in 0..10 {
            s.step(120).expect("steps");
            fastest = fastest.max(speed(&mut s));
        }
        assert!(fastest > 5.0, "{fastest}");
        // All or nothing, with the reason.
        let err = s
            .command(&[id, 777], &[None, None])
            .expect_err("an unknown id");
        assert_eq!(err, SessionError::NoVehicle(777));
        let err = s.command(&[id], &[]).expect_err("lengths differ");
        assert!(err.to_string().contains("0 values for 1"), "{err}");
    }

    #[test]
    fn custom_profiles_drive_as_lane_keepers_until_told_and_spawn_and_despawn_work() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = custom_ring(dir.path());
        // Without the session, a custom model is refused.
        let level = load_level(&path).expect("loads");
        assert!(Runner::new(level, "c", &RunOptions::default()).is_err());
        let mut s = Session::open(&path, Some(1), &[], BTreeMap::new(), None).expect("opens");
        s.step(1200).expect("steps");
        let v = s.vehicles();
        assert_eq!(v.id.len(), 6);
        let custom = v
            .models
            .iter()
            .position(|m| m == "Custom(keeper)")
            .expect("labelled");
        let mine: Vec<usize> = (0..6).filter(|&k| v.model[k] == custom as u32).collect();
        assert_eq!(mine.len(), 2);
        assert!(
            mine.iter().all(|&k| v.speed_mps[k] > 5.0),
            "{:?}",
            v.speed_mps
        );
        assert_eq!(v.profiles[v.profile[mine[0]] as usize], "mine");
        // A car added, then removed.
        let id = s
            .spawn("ring", 225.0, 0, 5.0, "mine", None)
            .expect("spawns");
        assert_eq!(id, 6);
        s.step(1).expect("steps");
        assert_eq!(s.vehicles().id.len(), 7);
        s.despawn(&[id]).expect("despawns");
        assert_eq!(s.vehicles().id.len(), 6);
        for (road, lane, profile, needle) in [
            ("nowhere", 0, "mine", "no road `nowhere`"),
            ("ring", 3, "mine", "1 lane(s), not lane 3"),
            (
                "ring",
                0,
                "ghost",
                "no driver profile `ghost`; the level's are auto, mine",
            ),
        ] {
            let err = s
                .spawn(road, 10.0, lane, 5.0, profile, None)
                .expect_err("refused");
            assert!(err.to_string().contains(needle), "{err}");
        }
    }

    #[test]
    fn the_summary_at_the_end_is_the_one_flockway_run_gives() {
        let overrides = [Override {
            key: "duration_s".into(),
            value: 40.0,
        }];
        let mut s = Session::open(
            &shipped("sugiyama_ring"),
            Some(2),
            &overrides,
            BTreeMap::new(),
            None,
        )
        .expect("opens");
        s.step(40 * 120).expect("steps");
        let mut level = load_level(&shipped("sugiyama_ring")).expect("loads");
        level.duration_s = 40.0;
        let options = RunOptions {
            seed: Some(2),
            assets: Some(find_assets_dir(Some(&shipped("sugiyama_ring")))),
            ..RunOptions::default()
        };
        let name = level_name(&level, &shipped("sugiyama_ring"));
        let run = Runner::new(level, &name, &options)
            .expect("runner")
            .finish()
            .expect("runs");
        let mine = s.summary();
        assert_eq!(mine.metrics, run.metrics);
        assert_eq!(mine.expectations, run.expectations);
        // Overrides: a profile's parameter, and the errors.
        let bad = [Override {
            key: "nobody.x".into(),
            value: 1.0,
        }];
        let err = Session::open(&shipped("sugiyama_ring"), None, &bad, BTreeMap::new(), None)
            .err()
            .expect("refused");
        assert!(err.to_string().contains("PROFILE.PARAMETER"), "{err}");
        let typo = [Override {
            key: "human.reaction_tme_s".into(),
            value: 1.0,
        }];
        let err = Session::open(
            &shipped("sugiyama_ring"),
            None,
            &typo,
            BTreeMap::new(),
            None,
        )
        .err()
        .expect("refused");
        assert!(err.to_string().contains("reaction_tme_s"), "{err}");
    }
}
