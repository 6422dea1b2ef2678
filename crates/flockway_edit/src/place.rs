//! Placement rules: what a click with a marker or prefab tool adds to the level — a unique
//! name, sensible defaults, and the driver profiles a first spawner needs.

use crate::command::{Command, MarkerKind};
use flockway_level::{
    DestroyerPlaceSpec, DestroyerSpec, Level, Range, SpawnerSpec, TriggerEffectSpec, TriggerSpec,
    crossroads, mixed_shares, reference_profiles, reference_vehicle_types, roundabout,
};
use flockway_road::SPEED_LIMIT_KMH;
use glam::DVec3;

/// Length of a new trigger stretch, metres.
pub const TRIGGER_LENGTH_M: f64 = 20.0;
/// How much faster than the road a new trigger's speed limit is, km/h.
pub const TRIGGER_RAISE_KMH: f64 = 20.0;

/// A marker to add: the command, and where the marker will be once it is applied.
#[derive(Debug, Clone, PartialEq)]
pub struct Placement {
    /// The command that adds it (with the profiles a first spawner needs).
    pub command: Command,
    /// Its kind.
    pub kind: MarkerKind,
    /// Its index in its list once added.
    pub index: usize,
    /// Whether the level got the standard vehicle types and driver profiles with it.
    pub added_profiles: bool,
}

/// The first `prefix N` that `taken` does not refuse.
fn unique(prefix: &str, taken: impl Fn(&str) -> bool) -> String {
    (1..)
        .map(|n| format!("{prefix} {n}"))
        .find(|n| !taken(n))
        .unwrap_or_default()
}

/// A marker of `kind` on road `road` at arc position `s_m` (a spawner on `lane`). A spawner in
/// a level without driver profiles brings the standard `autonomous` and `human` ones (and their
/// vehicle types), so it has something to spawn; a trigger is [`TRIGGER_LENGTH_M`] long inside
/// the road (a loop's may wrap past the join) and raises the limit by [`TRIGGER_RAISE_KMH`].
/// `None` if there is no such road.
pub fn place_marker(
    level: &Level,
    kind: MarkerKind,
    road: usize,
    lane: u32,
    s_m: f64,
    length_m: f64,
) -> Option<Placement> {
    let spec = level.roads.get(road)?;
    let name = spec.name.clone();
    let mut added_profiles = false;
    let (command, index) = match kind {
        MarkerKind::Spawner => {
            let mut setup = Vec::new();
            let mut with_profiles = level.clone();
            if level.driver_profiles.is_empty() {
                for v in reference_vehicle_types() {
                    if !level.vehicle_types.iter().any(|t| t.name == v.name) {
                        with_profiles.vehicle_types.push(v.clone());
                        setup.push(Command::AddVehicleType(v));
                    }
                }
                for p in reference_profiles() {
                    with_profiles.driver_profiles.push(p.clone());
                    setup.push(Command::AddDriverProfile(p));
                }
                added_profiles = true;
            }
            let n = unique("spawner", |n| level.spawners.iter().any(|s| s.name == n));
            setup.push(Command::AddSpawner(SpawnerSpec::new(
                &n,
                &name,
                lane,
                s_m,
                Range { min: 1.5, max: 3.0 },
                mixed_shares(&with_profiles),
            )));
            let command = if setup.len() == 1 {
                setup.remove(0)
            } else {
                Command::Batch {
                    label: "add spawner".to_owned(),
                    commands: setup,
                }
            };
            (command, level.spawners.len())
        }
        MarkerKind::Destroyer => {
            let n = unique("destroyer", |n| {
                level.destroyers.iter().any(|d| d.name == n)
            });
            (
                Command::AddDestroyer(DestroyerSpec {
                    name: n,
                    place: DestroyerPlaceSpec::OnRoad { road: name, s_m },
                    arrivals_only: false,
                }),
                level.destroyers.len(),
            )
        }
        MarkerKind::Trigger => {
            let n = unique("trigger", |n| level.triggers.iter().any(|t| t.name == n));
            let (from_m, to_m) = if spec.closed {
                (s_m, (s_m + TRIGGER_LENGTH_M) % length_m)
            } else {
                let from = s_m.min((length_m - TRIGGER_LENGTH_M).max(0.0));
                (from, (from + TRIGGER_LENGTH_M).min(length_m))
            };
            let kmh = (spec.speed_limit_kmh + TRIGGER_RAISE_KMH).min(300.0);
            (
                Command::AddTrigger(TriggerSpec {
                    name: n,
                    road: name,
                    from_m,
                    to_m,
                    lanes: None,
                    effect: TriggerEffectSpec::SpeedLimit {
                        kmh: kmh.clamp(*SPEED_LIMIT_KMH.start(), *SPEED_LIMIT_KMH.end()),
                    },
                }),
                level.triggers.len(),
            )
        }
    };
    Some(Placement {
        command,
        kind,
        index,
        added_profiles,
    })
}

/// A junction the editor places whole.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PrefabKind {
    /// A ring with four arms, each entry giving way to the ring.
    Roundabout,
    /// Four arms under a two-phase signal with permitted left turns.
    Crossroads,
}

impl PrefabKind {
    /// Its name's stem: "roundabout", "crossroads".
    pub fn stem(self) -> &'static str {
        match self {
            PrefabKind::Roundabout => "roundabout",
            PrefabKind::Crossroads => "crossroads",
        }
    }
}

/// A prefab of `kind` centred at `at`, named `roundabout N` / `crossroads N` with the first N
/// whose name (and its roads' `N …` prefix) no road or junction has: the command that places it
/// and its name.
pub fn place_prefab(level: &Level, kind: PrefabKind, at: DVec3) -> (Command, String) {
    let taken = |n: &str| {
        let prefix = format!("{n} ");
        level.roads.iter().any(|r| r.name.starts_with(&prefix))
            || level
                .junctions
                .iter()
                .any(|j| j.name == n || j.name.starts_with(&prefix))
    };
    let name = unique(kind.stem(), taken);
    let prefab = match kind {
        PrefabKind::Roundabout => roundabout(&name, at),
        PrefabKind::Crossroads => crossroads(&name, at),
    };
    (
        Command::AddPrefab {
            roads: prefab.roads,
            junctions: prefab.junctions,
        },
        name,
    )
}
