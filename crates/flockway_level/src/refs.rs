//! Every place a level names another of its items, walked by one visitor.
//!
//! Level items refer to each other by name: a spawner to its road, a junction's connection to
//! two roads, an expectation to a destroyer, a profile to a vehicle type. [`visit_references`]
//! is the one walk over all of them; [`references`], [`rename`] and [`remove_item`] are built on
//! it, so renaming and deleting an item treat every reference alike.

use crate::expect::{Metric, Qualifier};
use crate::schema::{DestroyerPlaceSpec, Level};
use flockway_road::Control;
use std::collections::BTreeSet;
use std::fmt;

/// The kind of a level item that others name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ItemKind {
    /// A road.
    Road,
    /// A junction.
    Junction,
    /// A driver profile.
    Profile,
    /// A vehicle type.
    VehicleType,
    /// A destroyer.
    Destroyer,
}

impl fmt::Display for ItemKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ItemKind::Road => "road",
            ItemKind::Junction => "junction",
            ItemKind::Profile => "driver profile",
            ItemKind::VehicleType => "vehicle type",
            ItemKind::Destroyer => "destroyer",
        })
    }
}

/// A named level item: what kind, and its name.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ItemRef {
    /// The kind of item.
    pub kind: ItemKind,
    /// Its name.
    pub name: String,
}

impl ItemRef {
    /// The item of `kind` named `name`.
    pub fn new(kind: ItemKind, name: &str) -> ItemRef {
        ItemRef {
            kind,
            name: name.to_owned(),
        }
    }
}

impl fmt::Display for ItemRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} `{}`", self.kind, self.name)
    }
}

/// A place in a level that names an item. Indices are positions in the level's lists.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Site {
    /// Road `.0`'s `next`.
    RoadNext(usize),
    /// Road `.0`'s link `.1`.
    RoadLink(usize, usize),
    /// Junction `.0`'s connection `.1`, its `from` road.
    ConnectionFrom(usize, usize),
    /// Junction `.0`'s connection `.1`, its `to` road.
    ConnectionTo(usize, usize),
    /// Junction `.0`'s major road `.1` (priority control).
    MajorRoad(usize, usize),
    /// Driver profile `.0`'s vehicle type.
    ProfileVehicle(usize),
    /// Spawner `.0`'s road.
    SpawnerRoad(usize),
    /// Spawner `.0`'s route `.1`, its road `.2`.
    RouteRoad(usize, usize, usize),
    /// Spawner `.0`'s destination.
    SpawnerDestination(usize),
    /// Spawner `.0`'s profile share `.1`.
    SpawnerProfile(usize, usize),
    /// Spawner `.0`'s departure `.1`, its profile.
    DepartureProfile(usize, usize),
    /// Destroyer `.0`'s road.
    DestroyerRoad(usize),
    /// Trigger `.0`'s road.
    TriggerRoad(usize),
    /// Detector `.0`'s road.
    DetectorRoad(usize),
    /// Initial vehicle group `.0`'s road.
    VehiclesRoad(usize),
    /// Initial vehicle group `.0`'s profile.
    VehiclesProfile(usize),
    /// Expectation `.0`'s qualifier.
    Expectation(usize),
}

impl Site {
    /// Where it is, in words: "spawner `s1`", "junction `j` connection 3".
    pub fn describe(&self, level: &Level) -> String {
        let name = |list: &[String], i: usize| list.get(i).cloned().unwrap_or_default();
        let roads: Vec<String> = level.roads.iter().map(|r| r.name.clone()).collect();
        let junctions: Vec<String> = level.junctions.iter().map(|j| j.name.clone()).collect();
        let spawners: Vec<String> = level.spawners.iter().map(|s| s.name.clone()).collect();
        match *self {
            Site::RoadNext(r) | Site::RoadLink(r, _) => format!("road `{}`", name(&roads, r)),
            Site::ConnectionFrom(j, c) | Site::ConnectionTo(j, c) => {
                format!("junction `{}` connection {}", name(&junctions, j), c + 1)
            }
            Site::MajorRoad(j, _) => format!("junction `{}` (major roads)", name(&junctions, j)),
            Site::ProfileVehicle(p) => format!(
                "driver profile `{}`",
                level.driver_profiles.get(p).map_or("", |p| p.name.as_str())
            ),
            Site::SpawnerRoad(s) | Site::SpawnerDestination(s) | Site::SpawnerProfile(s, _) => {
                format!("spawner `{}`", name(&spawners, s))
            }
            Site::RouteRoad(s, r, _) => format!(
                "spawner `{}` route `{}`",
                name(&spawners, s),
                level
                    .spawners
                    .get(s)
                    .and_then(|sp| sp.routes.get(r))
                    .map_or("", |r| r.name.as_str())
            ),
            Site::DepartureProfile(s, d) => {
                format!("spawner `{}` departure {}", name(&spawners, s), d + 1)
            }
            Site::DestroyerRoad(d) => format!(
                "destroyer `{}`",
                level.destroyers.get(d).map_or("", |d| d.name.as_str())
            ),
            Site::TriggerRoad(t) => format!(
                "trigger `{}`",
                level.triggers.get(t).map_or("", |t| t.name.as_str())
            ),
            Site::DetectorRoad(d) => format!(
                "detector `{}`",
                level.detectors.get(d).map_or("", |d| d.name.as_str())
            ),
            Site::VehiclesRoad(v) | Site::VehiclesProfile(v) => {
                format!("vehicle group {}", v + 1)
            }
            Site::Expectation(e) => format!(
                "expectation `{}`",
                level.expect.get(e).map(|e| e.key()).unwrap_or_default()
            ),
        }
    }
}

/// The kind of item an expectation's qualifier names, if it names one.
fn qualifier_kind(metric: Metric) -> Option<ItemKind> {
    match metric.info().qualifier {
        Qualifier::Road => Some(ItemKind::Road),
        Qualifier::Destroyer => Some(ItemKind::Destroyer),
        Qualifier::Profile => Some(ItemKind::Profile),
        Qualifier::Junction => Some(ItemKind::Junction),
        Qualifier::None => None,
    }
}

/// Calls `f` with every reference in the level: where it stands, the kind of item it names, and
/// the name, which `f` may change. The one walk over every place a level names an item.
pub fn visit_references(level: &mut Level, mut f: impl FnMut(Site, ItemKind, &mut String)) {
    use ItemKind::{Profile, Road, VehicleType};
    for (r, road) in level.roads.iter_mut().enumerate() {
        if let Some(n) = &mut road.next {
            f(Site::RoadNext(r), Road, n);
        }
        for (k, l) in road.links.iter_mut().enumerate() {
            f(Site::RoadLink(r, k), Road, &mut l.to);
        }
    }
    for (j, junction) in level.junctions.iter_mut().enumerate() {
        for (c, conn) in junction.connections.iter_mut().enumerate() {
            f(Site::ConnectionFrom(j, c), Road, &mut conn.from);
            f(Site::ConnectionTo(j, c), Road, &mut conn.to);
        }
        if let Control::Priority { major, .. } = &mut junction.control {
            for (k, m) in major.iter_mut().enumerate() {
                f(Site::MajorRoad(j, k), Road, m);
            }
        }
    }
    for (p, profile) in level.driver_profiles.iter_mut().enumerate() {
        f(Site::ProfileVehicle(p), VehicleType, &mut profile.vehicle);
    }
    for (s, spawner) in level.spawners.iter_mut().enumerate() {
        f(Site::SpawnerRoad(s), Road, &mut spawner.road);
        for (r, route) in spawner.routes.iter_mut().enumerate() {
            for (k, road) in route.roads.iter_mut().enumerate() {
                f(Site::RouteRoad(s, r, k), Road, road);
            }
        }
        if let Some(d) = &mut spawner.destination {
            f(Site::SpawnerDestination(s), Road, d);
        }
        for (k, share) in spawner.profiles.iter_mut().enumerate() {
            f(Site::SpawnerProfile(s, k), Profile, &mut share.profile);
        }
        for (k, d) in spawner.departures.iter_mut().enumerate() {
            f(Site::DepartureProfile(s, k), Profile, &mut d.profile);
        }
    }
    for (d, destroyer) in level.destroyers.iter_mut().enumerate() {
        if let DestroyerPlaceSpec::OnRoad { road, .. } = &mut destroyer.place {
            f(Site::DestroyerRoad(d), Road, road);
        }
    }
    for (t, trigger) in level.triggers.iter_mut().enumerate() {
        f(Site::TriggerRoad(t), Road, &mut trigger.road);
    }
    for (d, detector) in level.detectors.iter_mut().enumerate() {
        f(Site::DetectorRoad(d), Road, &mut detector.road);
    }
    for (v, group) in level.vehicles.iter_mut().enumerate() {
        f(Site::VehiclesRoad(v), Road, &mut group.road);
        f(Site::VehiclesProfile(v), Profile, &mut group.profile);
    }
    for (e, expectation) in level.expect.iter_mut().enumerate() {
        if let (Some(kind), Some(q)) = (
            qualifier_kind(expectation.metric),
            &mut expectation.qualifier,
        ) {
            f(Site::Expectation(e), kind, q);
        }
    }
}

/// Every place the level names `item`, in level order.
pub fn references(level: &Level, item: &ItemRef) -> Vec<Site> {
    // The walk is written once, over a mutable level: a copy costs less than a second walk
    // that could drift from the first.
    let mut copy = level.clone();
    let mut sites = Vec::new();
    visit_references(&mut copy, |site, kind, name| {
        if kind == item.kind && *name == item.name {
            sites.push(site);
        }
    });
    sites
}

/// Makes every reference to `item` name `new` instead (the item itself is not renamed).
pub fn rename(level: &mut Level, item: &ItemRef, new: &str) {
    visit_references(level, |_, kind, name| {
        if kind == item.kind && *name == item.name {
            *name = new.to_owned();
        }
    });
}

/// One thing [`remove_item`] takes out, ordered so that, taken in reverse, a removal never
/// shifts the index of another one still to come.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Removal {
    Next(usize),
    Link(usize, usize),
    Connection(usize, usize),
    Major(usize, usize),
    Spawner(usize),
    // After `Spawner`: taken (in reverse) before any spawner goes, while indices hold.
    Route(usize, usize),
    Destination(usize),
    Destroyer(usize),
    Trigger(usize),
    Detector(usize),
    Vehicles(usize),
    Expectation(usize),
}

/// Whether deleting an item takes the item that refers to it along, or must be refused while
/// the reference exists: a road takes its markers, routes and connections with it; a profile
/// used by a spawner, or a vehicle type a profile drives, is refused.
pub fn blocks_removal(site: Site) -> bool {
    matches!(
        site,
        Site::ProfileVehicle(_)
            | Site::SpawnerProfile(..)
            | Site::DepartureProfile(..)
            | Site::VehiclesProfile(_)
    )
}

/// Deletes `item` from the level with everything that cannot stand without it: the markers and
/// vehicle groups on a road, the routes and junction connections through it, links and `next`
/// onto it, expectations on it (and on a destroyer that stood on it). A signal's phases lose
/// the letters of the connections removed. Returns the references that block the deletion
/// instead (see [`blocks_removal`]), leaving the level unchanged.
pub fn remove_item(level: &mut Level, item: &ItemRef) -> Result<(), Vec<Site>> {
    let sites = references(level, item);
    let blocking: Vec<Site> = sites
        .iter()
        .copied()
        .filter(|s| blocks_removal(*s))
        .collect();
    if !blocking.is_empty() {
        return Err(blocking);
    }
    let mut removals: BTreeSet<Removal> = sites
        .iter()
        .filter_map(|site| match *site {
            Site::RoadNext(r) => Some(Removal::Next(r)),
            Site::RoadLink(r, k) => Some(Removal::Link(r, k)),
            Site::ConnectionFrom(j, c) | Site::ConnectionTo(j, c) => {
                Some(Removal::Connection(j, c))
            }
            Site::MajorRoad(j, k) => Some(Removal::Major(j, k)),
            Site::SpawnerRoad(s) => Some(Removal::Spawner(s)),
            Site::RouteRoad(s, r, _) => Some(Removal::Route(s, r)),
            Site::SpawnerDestination(s) => Some(Removal::Destination(s)),
            Site::DestroyerRoad(d) => Some(Removal::Destroyer(d)),
            Site::TriggerRoad(t) => Some(Removal::Trigger(t)),
            Site::DetectorRoad(d) => Some(Removal::Detector(d)),
            Site::VehiclesRoad(v) => Some(Removal::Vehicles(v)),
            Site::Expectation(e) => Some(Removal::Expectation(e)),
            _ => None,
        })
        .collect();
    // A destroyer that goes takes the expectations on it along.
    let destroyers: Vec<ItemRef> = removals
        .iter()
        .filter_map(|r| match r {
            Removal::Destroyer(d) => level
                .destroyers
                .get(*d)
                .map(|d| ItemRef::new(ItemKind::Destroyer, &d.name)),
            _ => None,
        })
        .collect();
    for d in &destroyers {
        for site in references(level, d) {
            if let Site::Expectation(e) = site {
                removals.insert(Removal::Expectation(e));
            }
        }
    }
    for removal in removals.into_iter().rev() {
        match removal {
            Removal::Next(r) => level.roads[r].next = None,
            Removal::Link(r, k) => drop(level.roads[r].links.remove(k)),
            Removal::Connection(j, c) => {
                let junction = &mut level.junctions[j];
                junction.connections.remove(c);
                if let Some(program) = &mut junction.signal {
                    for phase in &mut program.phases {
                        if c < phase.state.chars().count() {
                            phase.state = phase
                                .state
                                .chars()
                                .enumerate()
                                .filter(|(k, _)| *k != c)
                                .map(|(_, ch)| ch)
                                .collect();
                        }
                    }
                }
            }
            Removal::Major(j, k) => {
                if let Control::Priority { major, .. } = &mut level.junctions[j].control {
                    major.remove(k);
                }
            }
            Removal::Route(s, r) => {
                let spawner = &mut level.spawners[s];
                let name = spawner.routes.remove(r).name;
                // A departure on the route takes one drawn by weight, as the others do.
                for d in &mut spawner.departures {
                    if d.route.as_deref() == Some(name.as_str()) {
                        d.route = None;
                    }
                }
            }
            Removal::Destination(s) => level.spawners[s].destination = None,
            Removal::Spawner(s) => drop(level.spawners.remove(s)),
            Removal::Destroyer(d) => drop(level.destroyers.remove(d)),
            Removal::Trigger(t) => drop(level.triggers.remove(t)),
            Removal::Detector(d) => drop(level.detectors.remove(d)),
            Removal::Vehicles(v) => drop(level.vehicles.remove(v)),
            Removal::Expectation(e) => drop(level.expect.remove(e)),
        }
    }
    let position = match item.kind {
        ItemKind::Road => level.roads.iter().position(|r| r.name == item.name),
        ItemKind::Junction => level.junctions.iter().position(|j| j.name == item.name),
        ItemKind::Profile => level
            .driver_profiles
            .iter()
            .position(|p| p.name == item.name),
        ItemKind::VehicleType => level.vehicle_types.iter().position(|v| v.name == item.name),
        ItemKind::Destroyer => level.destroyers.iter().position(|d| d.name == item.name),
    };
    if let Some(k) = position {
        match item.kind {
            ItemKind::Road => drop(level.roads.remove(k)),
            ItemKind::Junction => drop(level.junctions.remove(k)),
            ItemKind::Profile => drop(level.driver_profiles.remove(k)),
            ItemKind::VehicleType => drop(level.vehicle_types.remove(k)),
            ItemKind::Destroyer => drop(level.destroyers.remove(k)),
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::schema::{ProfileShare, RouteSpec, SpawnerSpec};
    use flockway_road::RoadSpec;
    use glam::DVec3;

    fn spawner(name: &str, road: &str, route: &[&str]) -> SpawnerSpec {
        let share = ProfileShare {
            profile: "p".to_owned(),
            weight: 1.0,
        };
        let every = crate::Range { min: 2.0, max: 3.0 };
        SpawnerSpec {
            routes: vec![RouteSpec {
                name: "r".to_owned(),
                roads: route.iter().map(|r| (*r).to_owned()).collect(),
                weight: 1.0,
            }],
            ..SpawnerSpec::new(name, road, 0, 1.0, every, vec![share])
        }
    }

    #[test]
    fn a_removed_spawner_does_not_shift_the_route_removed_from_the_next_one() {
        let mut level = Level::new(1, 60.0);
        for (name, x) in [("a", 0.0), ("b", 100.0), ("c", 200.0)] {
            level.roads.push(RoadSpec::through(
                name,
                1,
                50.0,
                &[DVec3::new(x, 0.0, 0.0), DVec3::new(x + 90.0, 0.0, 0.0)],
            ));
        }
        // Spawner 0 stands on `b`; spawner 1 and 2 route through it; spawner 3 does not.
        level.spawners = vec![
            spawner("on b", "b", &["b", "c"]),
            spawner("via b", "a", &["a", "b"]),
            spawner("via b too", "a", &["a", "b", "c"]),
            spawner("elsewhere", "a", &["a"]),
        ];
        let b = ItemRef::new(ItemKind::Road, "b");
        assert_eq!(references(&level, &b).len(), 4);
        remove_item(&mut level, &b).expect("nothing blocks a road");
        let names: Vec<&str> = level.spawners.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["via b", "via b too", "elsewhere"]);
        assert!(level.spawners[0].routes.is_empty());
        assert!(level.spawners[1].routes.is_empty());
        assert_eq!(
            level.spawners[2].routes.len(),
            1,
            "the route not through `b` stays"
        );
        assert!(level.road("b").is_none());
        assert!(references(&level, &b).is_empty());
    }
}
