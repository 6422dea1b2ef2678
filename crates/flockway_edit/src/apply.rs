//! Running one [`Command`] on a level, by concern: road geometry, roads and their links,
//! markers, the level's settings and lists, junctions. Renames and deletions go through the
//! level's reference layer ([`flockway_level::rename`], [`flockway_level::remove_item`]), so
//! every place that names an item follows it.

use crate::command::{Command, MarkerKind, Target};
use crate::error::{EditError, in_range};
use crate::joins;
use flockway_level::{DestroyerPlaceSpec, ItemKind, ItemRef, Level, remove_item, rename};
use flockway_road::{ControlPoint, JunctionSpec, LANE_WIDTH_M, LANES, RoadSpec, SPEED_LIMIT_KMH};
use glam::DVec3;

/// Runs one command on a level; on error the level may be partly changed (callers apply to a
/// copy).
pub(crate) fn apply(level: &mut Level, command: &Command) -> Result<(), EditError> {
    match command {
        Command::AddRoad { .. }
        | Command::AppendPoint { .. }
        | Command::InsertPoint { .. }
        | Command::MovePoint { .. }
        | Command::DeletePoint { .. }
        | Command::SetPoint { .. }
        | Command::SetClosed { .. } => geometry(level, command),
        Command::DeleteRoad { .. }
        | Command::Connect { .. }
        | Command::SetLinks { .. }
        | Command::JoinEnd { .. }
        | Command::JoinSide { .. }
        | Command::JoinExit { .. }
        | Command::SetRoad { .. } => roads(level, command),
        Command::AddSpawner(_)
        | Command::SetSpawner(..)
        | Command::AddDestroyer(_)
        | Command::SetDestroyer(..)
        | Command::AddTrigger(_)
        | Command::SetTrigger(..)
        | Command::AddDetector(_)
        | Command::SetDetector(..)
        | Command::DeleteDetector(_)
        | Command::MoveMarker { .. }
        | Command::DeleteMarker { .. } => markers(level, command),
        Command::AddPrefab { .. } | Command::SetJunction(..) | Command::DeleteJunction(_) => {
            junctions(level, command)
        }
        Command::Batch { commands, .. } => {
            for c in commands {
                apply(level, c)?;
            }
            Ok(())
        }
        Command::Set { item, field, value } => set_field(level, item, field, value),
        _ => settings(level, command),
    }
}

/// Item `index` of a list, or why there is none.
fn item<'a, T>(
    list: &'a mut [T],
    what: &'static str,
    index: usize,
) -> Result<&'a mut T, EditError> {
    let count = list.len();
    list.get_mut(index)
        .ok_or(EditError::NoSuch { what, index, count })
}

fn road_mut(level: &mut Level, road: usize) -> Result<&mut RoadSpec, EditError> {
    item(&mut level.roads, "road", road)
}

fn point_index(spec: &RoadSpec, index: usize) -> Result<usize, EditError> {
    if index < spec.points.len() {
        Ok(index)
    } else {
        Err(EditError::NoPoint {
            road: spec.name.clone(),
            index,
            count: spec.points.len(),
        })
    }
}

fn finite(v: DVec3) -> Result<DVec3, EditError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(EditError::NotFinite(v))
    }
}

/// The road named `name`, or the error that says there is none.
fn known_road<'a>(level: &'a Level, name: &str) -> Result<&'a RoadSpec, EditError> {
    level
        .road(name)
        .ok_or_else(|| EditError::Unknown(ItemRef::new(ItemKind::Road, name)))
}

/// Deletes `item` and what cannot stand without it, or refuses, naming what uses it.
fn delete(level: &mut Level, item: ItemRef) -> Result<(), EditError> {
    remove_item(level, &item).map_err(|sites| EditError::InUse {
        by: sites.iter().map(|s| s.describe(level)).collect(),
        item,
    })
}

/// Control points and loops.
fn geometry(level: &mut Level, command: &Command) -> Result<(), EditError> {
    match command {
        Command::AddRoad { at } => {
            let at = finite(*at)?;
            let mut n = level.roads.len() + 1;
            while level.road(&format!("road {n}")).is_some() {
                n += 1;
            }
            let mut spec = RoadSpec::through(&format!("road {n}"), 2, 50.0, &[]);
            spec.points.push(ControlPoint::at(at));
            level.roads.push(spec);
        }
        Command::AppendPoint { road, at } => {
            let at = finite(*at)?;
            road_mut(level, *road)?.points.push(ControlPoint::at(at));
        }
        Command::InsertPoint { road, index, at } => {
            let at = finite(*at)?;
            let spec = road_mut(level, *road)?;
            if *index > spec.points.len() {
                return Err(EditError::NoPoint {
                    road: spec.name.clone(),
                    index: *index,
                    count: spec.points.len(),
                });
            }
            spec.points.insert(*index, ControlPoint::at(at));
        }
        Command::MovePoint { road, index, to } => {
            let to = finite(*to)?;
            let spec = road_mut(level, *road)?;
            let i = point_index(spec, *index)?;
            spec.points[i].pos = to;
        }
        Command::DeletePoint { road, index } => {
            let spec = road_mut(level, *road)?;
            let i = point_index(spec, *index)?;
            spec.points.remove(i);
            if spec.points.is_empty() {
                return roads(level, &Command::DeleteRoad { road: *road });
            }
        }
        Command::SetPoint { road, index, point } => {
            finite(point.pos)?;
            let spec = road_mut(level, *road)?;
            let i = point_index(spec, *index)?;
            spec.points[i] = point.clone();
        }
        Command::SetClosed { road, closed } => {
            let spec = road_mut(level, *road)?;
            spec.closed = *closed;
            if *closed {
                spec.next = None;
            }
        }
        _ => unreachable!("dispatched by `apply`"),
    }
    Ok(())
}

/// Roads as a whole: their settings, links and joins, deletion.
fn roads(level: &mut Level, command: &Command) -> Result<(), EditError> {
    match command {
        Command::DeleteRoad { road } => {
            let name = road_mut(level, *road)?.name.clone();
            delete(level, ItemRef::new(ItemKind::Road, &name))?;
        }
        Command::Connect { road, next } => {
            if let Some(n) = next {
                known_road(level, n)?;
            }
            let spec = road_mut(level, *road)?;
            if next.as_deref() == Some(spec.name.as_str()) {
                return Err(EditError::OntoItself);
            }
            spec.next = next.clone();
            if next.is_some() {
                spec.closed = false;
            }
        }
        Command::SetLinks { road, links } => {
            let from = road_mut(level, *road)?.clone();
            for l in links {
                let to = known_road(level, &l.to)?;
                if l.to == from.name {
                    return Err(EditError::OntoItself);
                }
                if let Some((a, b)) = l
                    .lanes
                    .iter()
                    .find(|(a, b)| *a >= from.lanes || *b >= to.lanes)
                {
                    return Err(EditError::LinkLane {
                        from: from.name.clone(),
                        from_lane: *a,
                        from_lanes: from.lanes,
                        to: to.name.clone(),
                        to_lane: *b,
                        to_lanes: to.lanes,
                    });
                }
            }
            let spec = road_mut(level, *road)?;
            spec.next = None;
            spec.links = links.clone();
            if !links.is_empty() {
                spec.closed = false;
            }
        }
        Command::JoinEnd { road, onto } => joins::join_end(level, *road, onto)?,
        Command::JoinSide { road, onto, s_m } => {
            joins::join_side(level, *road, onto, *s_m)?;
        }
        Command::JoinExit { road, onto, s_m } => {
            joins::join_exit(level, *road, onto, *s_m)?;
        }
        Command::SetRoad {
            road,
            name,
            lanes,
            lane_width_m,
            speed_limit_kmh,
        } => set_road(level, *road, name, *lanes, *lane_width_m, *speed_limit_kmh)?,
        _ => unreachable!("dispatched by `apply`"),
    }
    Ok(())
}

/// A road's own settings, within the schema's limits; a new name is followed everywhere.
fn set_road(
    level: &mut Level,
    road: usize,
    name: &str,
    lanes: u32,
    lane_width_m: f64,
    speed_limit_kmh: f64,
) -> Result<(), EditError> {
    let name = name.trim().to_owned();
    let old = road_mut(level, road)?.name.clone();
    if name.is_empty() {
        return Err(EditError::EmptyName(ItemKind::Road));
    }
    if name != old && level.road(&name).is_some() {
        return Err(EditError::NameTaken(ItemRef::new(ItemKind::Road, &name)));
    }
    if !LANES.contains(&lanes) {
        return Err(EditError::OutOfRange {
            field: "lanes",
            value: f64::from(lanes),
            min: f64::from(*LANES.start()),
            max: f64::from(*LANES.end()),
            unit: "",
        });
    }
    in_range("lane width", lane_width_m, &LANE_WIDTH_M, " m")?;
    in_range("speed limit", speed_limit_kmh, &SPEED_LIMIT_KMH, " km/h")?;
    let spec = road_mut(level, road)?;
    spec.name = name.clone();
    spec.lanes = lanes;
    spec.lane_width_m = lane_width_m;
    spec.speed_limit_kmh = speed_limit_kmh;
    if name != old {
        rename(level, &ItemRef::new(ItemKind::Road, &old), &name);
    }
    // Fewer lanes: what stood in a lane that is gone moves to the new leftmost one.
    let top = lanes - 1;
    for s in level.spawners.iter_mut().filter(|s| s.road == name) {
        s.lane = s.lane.min(top);
    }
    for v in level.vehicles.iter_mut().filter(|v| v.road == name) {
        v.lane = v.lane.min(top);
    }
    for t in level.triggers.iter_mut().filter(|t| t.road == name) {
        if let Some(l) = &mut t.lanes {
            l.retain(|k| *k <= top);
            if l.is_empty() {
                t.lanes = None;
            }
        }
    }
    Ok(())
}

/// Spawners, destroyers, triggers and detectors.
fn markers(level: &mut Level, command: &Command) -> Result<(), EditError> {
    match command {
        Command::AddSpawner(s) => level.spawners.push(s.clone()),
        Command::AddDestroyer(d) => level.destroyers.push(d.clone()),
        Command::AddTrigger(t) => level.triggers.push(t.clone()),
        Command::SetSpawner(i, s) => *item(&mut level.spawners, "spawner", *i)? = s.clone(),
        Command::SetDestroyer(i, d) => {
            let old = item(&mut level.destroyers, "destroyer", *i)?.name.clone();
            level.destroyers[*i] = d.clone();
            if d.name != old {
                rename(level, &ItemRef::new(ItemKind::Destroyer, &old), &d.name);
            }
        }
        Command::SetTrigger(i, t) => *item(&mut level.triggers, "trigger", *i)? = t.clone(),
        Command::AddDetector(d) => level.detectors.push(d.clone()),
        Command::SetDetector(i, d) => *item(&mut level.detectors, "detector", *i)? = d.clone(),
        Command::DeleteDetector(i) => {
            item(&mut level.detectors, "detector", *i)?;
            level.detectors.remove(*i);
        }
        Command::MoveMarker { kind, index, s_m } => {
            if !s_m.is_finite() || *s_m < 0.0 {
                return Err(EditError::BadArc(*s_m));
            }
            match kind {
                MarkerKind::Spawner => item(&mut level.spawners, "spawner", *index)?.s_m = *s_m,
                MarkerKind::Destroyer => {
                    match &mut item(&mut level.destroyers, "destroyer", *index)?.place {
                        DestroyerPlaceSpec::OnRoad { s_m: at, .. } => *at = *s_m,
                        DestroyerPlaceSpec::Volume { .. } => return Err(EditError::NotOnRoad),
                    }
                }
                MarkerKind::Trigger => {
                    let t = item(&mut level.triggers, "trigger", *index)?;
                    let len = t.to_m - t.from_m;
                    t.from_m = *s_m;
                    t.to_m = *s_m + len;
                }
            }
        }
        Command::DeleteMarker { kind, index } => match kind {
            MarkerKind::Spawner => {
                item(&mut level.spawners, "spawner", *index)?;
                level.spawners.remove(*index);
            }
            MarkerKind::Destroyer => {
                let name = item(&mut level.destroyers, "destroyer", *index)?
                    .name
                    .clone();
                delete(level, ItemRef::new(ItemKind::Destroyer, &name))?;
            }
            MarkerKind::Trigger => {
                item(&mut level.triggers, "trigger", *index)?;
                level.triggers.remove(*index);
            }
        },
        _ => unreachable!("dispatched by `apply`"),
    }
    Ok(())
}

/// The level's settings and its lists of vehicle types, profiles, expectations and vehicles.
fn settings(level: &mut Level, command: &Command) -> Result<(), EditError> {
    match command {
        Command::SetLevelInfo {
            name,
            description,
            seed,
            duration_s,
            telemetry,
        } => {
            level.name = name.trim().to_owned();
            level.description = description.clone();
            level.seed = *seed;
            level.duration_s = *duration_s;
            level.telemetry = telemetry.clone();
        }
        Command::AddVehicleType(v) => level.vehicle_types.push(v.clone()),
        Command::SetVehicleType(i, v) => {
            let old = item(&mut level.vehicle_types, "vehicle type", *i)?
                .name
                .clone();
            level.vehicle_types[*i] = v.clone();
            if v.name != old {
                rename(level, &ItemRef::new(ItemKind::VehicleType, &old), &v.name);
            }
        }
        Command::DeleteVehicleType(i) => {
            let name = item(&mut level.vehicle_types, "vehicle type", *i)?
                .name
                .clone();
            delete(level, ItemRef::new(ItemKind::VehicleType, &name))?;
        }
        Command::AddDriverProfile(p) => level.driver_profiles.push(p.clone()),
        Command::SetDriverProfile(i, p) => {
            let old = item(&mut level.driver_profiles, "driver profile", *i)?
                .name
                .clone();
            level.driver_profiles[*i] = p.clone();
            if p.name != old {
                rename(level, &ItemRef::new(ItemKind::Profile, &old), &p.name);
            }
        }
        Command::DeleteDriverProfile(i) => {
            let name = item(&mut level.driver_profiles, "driver profile", *i)?
                .name
                .clone();
            delete(level, ItemRef::new(ItemKind::Profile, &name))?;
        }
        Command::SetExpectations(list) => level.expect = list.clone(),
        Command::AddVehicles(v) => level.vehicles.push(v.clone()),
        Command::SetVehicles(i, v) => {
            *item(&mut level.vehicles, "vehicle group", *i)? = v.clone();
        }
        Command::DeleteVehicles(i) => {
            item(&mut level.vehicles, "vehicle group", *i)?;
            level.vehicles.remove(*i);
        }
        _ => unreachable!("dispatched by `apply`"),
    }
    Ok(())
}

/// Junctions: prefabs placed, edited, deleted.
fn junctions(level: &mut Level, command: &Command) -> Result<(), EditError> {
    match command {
        Command::AddPrefab { roads, junctions } => {
            level.roads.extend(roads.iter().cloned());
            level.junctions.extend(junctions.iter().cloned());
        }
        Command::SetJunction(i, j) => set_junction(level, *i, j)?,
        Command::DeleteJunction(i) => {
            let name = item(&mut level.junctions, "junction", *i)?.name.clone();
            delete(level, ItemRef::new(ItemKind::Junction, &name))?;
        }
        _ => unreachable!("dispatched by `apply`"),
    }
    Ok(())
}

/// Replaces junction `i`; expectations on it follow a new name.
fn set_junction(level: &mut Level, i: usize, j: &JunctionSpec) -> Result<(), EditError> {
    let name = j.name.trim();
    if name.is_empty() {
        return Err(EditError::EmptyName(ItemKind::Junction));
    }
    let taken = level
        .junctions
        .iter()
        .enumerate()
        .any(|(k, o)| k != i && o.name == j.name);
    if taken {
        return Err(EditError::NameTaken(ItemRef::new(
            ItemKind::Junction,
            &j.name,
        )));
    }
    let old = item(&mut level.junctions, "junction", i)?.name.clone();
    level.junctions[i] = j.clone();
    if j.name != old {
        rename(level, &ItemRef::new(ItemKind::Junction, &old), &j.name);
    }
    Ok(())
}

/// `item` with the field at the dotted `path` (as the level file writes it) set to `value`,
/// through the item's serde form: a missing last key is added (an optional field left out of
/// the file), a wrong one is refused by the item's own deserialiser.
fn with_field<T: serde::Serialize + serde::de::DeserializeOwned>(
    item: &T,
    target: &Target,
    path: &str,
    value: &ron::Value,
) -> Result<T, EditError> {
    let bad = |reason: String| EditError::BadField {
        target: target.clone(),
        field: path.to_owned(),
        reason,
    };
    let mut json = serde_json::to_value(item).map_err(|e| bad(e.to_string()))?;
    let new = serde_json::to_value(value).map_err(|e| bad(e.to_string()))?;
    let keys: Vec<&str> = path.split('.').collect();
    let mut at = &mut json;
    for (k, key) in keys.iter().enumerate() {
        let last = k + 1 == keys.len();
        at = match at {
            serde_json::Value::Object(map) => {
                if last {
                    map.entry(key.to_string())
                        .or_insert(serde_json::Value::Null)
                } else {
                    map.get_mut(*key)
                        .ok_or_else(|| bad(format!("it has no `{key}`")))?
                }
            }
            serde_json::Value::Array(list) => {
                let n = list.len();
                key.parse::<usize>()
                    .ok()
                    .and_then(|i| list.get_mut(i))
                    .ok_or_else(|| bad(format!("`{key}` is not an index of a list of {n}")))?
            }
            _ => return Err(bad(format!("there is nothing inside it at `{key}`"))),
        };
    }
    *at = new;
    serde_json::from_value(json).map_err(|e| bad(e.to_string()))
}

/// Position of the item named `name` in `list`, or the error that there is none.
fn named<T>(
    list: &[T],
    name_of: impl Fn(&T) -> &str,
    target: &Target,
    name: &str,
) -> Result<usize, EditError> {
    list.iter()
        .position(|x| name_of(x) == name)
        .ok_or_else(|| EditError::NoTarget(target.clone()))
}

/// [`Command::Set`]: one field of a named item, through the item's own edit.
fn set_field(
    level: &mut Level,
    target: &Target,
    path: &str,
    value: &ron::Value,
) -> Result<(), EditError> {
    match target {
        Target::Level => set_level_field(level, target, path, value),
        Target::Road(name) => {
            let i = named(&level.roads, |r| r.name.as_str(), target, name)?;
            let new = with_field(&level.roads[i], target, path, value)?;
            // Name, lanes, width and limit as the inspector sets them (checked, followed).
            set_road(
                level,
                i,
                &new.name,
                new.lanes,
                new.lane_width_m,
                new.speed_limit_kmh,
            )?;
            let renamed = level.roads[i].name.clone();
            level.roads[i] = RoadSpec {
                name: renamed,
                ..new
            };
            Ok(())
        }
        Target::Junction(name) => {
            let i = named(&level.junctions, |j| j.name.as_str(), target, name)?;
            let new = with_field(&level.junctions[i], target, path, value)?;
            set_junction(level, i, &new)
        }
        Target::Spawner(name) => {
            let i = named(&level.spawners, |s| s.name.as_str(), target, name)?;
            let new = with_field(&level.spawners[i], target, path, value)?;
            markers(level, &Command::SetSpawner(i, new))
        }
        Target::Destroyer(name) => {
            let i = named(&level.destroyers, |d| d.name.as_str(), target, name)?;
            let new = with_field(&level.destroyers[i], target, path, value)?;
            markers(level, &Command::SetDestroyer(i, new))
        }
        Target::Trigger(name) => {
            let i = named(&level.triggers, |t| t.name.as_str(), target, name)?;
            let new = with_field(&level.triggers[i], target, path, value)?;
            markers(level, &Command::SetTrigger(i, new))
        }
        Target::Detector(name) => {
            let i = named(&level.detectors, |d| d.name.as_str(), target, name)?;
            let new = with_field(&level.detectors[i], target, path, value)?;
            markers(level, &Command::SetDetector(i, new))
        }
        Target::Profile(name) => {
            let i = named(&level.driver_profiles, |p| p.name.as_str(), target, name)?;
            let new = with_field(&level.driver_profiles[i], target, path, value)?;
            settings(level, &Command::SetDriverProfile(i, new))
        }
        Target::VehicleType(name) => {
            let i = named(&level.vehicle_types, |v| v.name.as_str(), target, name)?;
            let new = with_field(&level.vehicle_types[i], target, path, value)?;
            settings(level, &Command::SetVehicleType(i, new))
        }
    }
}

/// A field of the level's own settings.
fn set_level_field(
    level: &mut Level,
    target: &Target,
    path: &str,
    value: &ron::Value,
) -> Result<(), EditError> {
    let (head, rest) = path
        .split_once('.')
        .map_or((path, None), |(h, r)| (h, Some(r)));
    // A top-level field set whole is the value itself; a nested one goes through its struct.
    fn field<T: serde::Serialize + serde::de::DeserializeOwned>(
        current: &T,
        target: &Target,
        path: &str,
        rest: Option<&str>,
        value: &ron::Value,
    ) -> Result<T, EditError> {
        match rest {
            Some(r) => with_field(current, target, r, value),
            None => value.clone().into_rust().map_err(|e| EditError::BadField {
                target: target.clone(),
                field: path.to_owned(),
                reason: e.to_string(),
            }),
        }
    }
    match head {
        "name" => level.name = field(&level.name, target, path, rest, value)?,
        "description" => level.description = field(&level.description, target, path, rest, value)?,
        "seed" => level.seed = field(&level.seed, target, path, rest, value)?,
        "duration_s" => level.duration_s = field(&level.duration_s, target, path, rest, value)?,
        "telemetry" => level.telemetry = field(&level.telemetry, target, path, rest, value)?,
        "ssm" => level.ssm = field(&level.ssm, target, path, rest, value)?,
        _ => {
            return Err(EditError::BadField {
                target: target.clone(),
                field: path.to_owned(),
                reason: "the level's settings are `name`, `description`, `seed`, `duration_s`, \
                         `telemetry` and `ssm` (roads, markers and the rest by their own name)"
                    .to_owned(),
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Editor;
    use flockway_level::{
        Check, Expectation, Metric, ProfileShare, RouteSpec, SpawnerSpec, Template, crossroads,
        references, validate,
    };
    use flockway_road::Control;

    /// A signalised crossroads with a spawner routed through it and expectations on one of its
    /// roads and on the junction: every kind of reference to a road.
    fn crossroads_level() -> Level {
        let mut level = Template::Empty.level("refs");
        let prefab = crossroads("x", DVec3::ZERO);
        level.roads = prefab.roads;
        level.junctions = prefab.junctions;
        let profile = level.driver_profiles[0].name.clone();
        let share = ProfileShare {
            profile,
            weight: 1.0,
        };
        let every = flockway_level::Range { min: 2.0, max: 3.0 };
        level.spawners.push(SpawnerSpec {
            routes: vec![RouteSpec {
                name: "east".to_owned(),
                roads: vec!["x west in".to_owned(), "x east out".to_owned()],
                weight: 1.0,
            }],
            ..SpawnerSpec::new("s", "x west in", 0, 5.0, every, vec![share])
        });
        for (metric, on, check) in [
            (Metric::RoadLengthM, "x east out", Check::Gt(10.0)),
            (Metric::JunctionDelayS, "x", Check::Lt(60.0)),
        ] {
            level.expect.push(Expectation {
                metric,
                qualifier: Some(on.to_owned()),
                check,
            });
        }
        assert!(validate(&level).is_empty(), "{:?}", validate(&level));
        level
    }

    fn road_index(level: &Level, name: &str) -> usize {
        level.roads.iter().position(|r| r.name == name).expect(name)
    }

    #[test]
    fn deleting_a_road_a_junction_a_route_and_an_expectation_use_takes_each_along_and_undoes() {
        let level = crossroads_level();
        let mut e = Editor::with_level(level.clone(), None);
        let junction = &level.junctions[0];
        let road = ItemRef::new(ItemKind::Road, "x east out");
        let uses: Vec<String> = references(&level, &road)
            .iter()
            .map(|s| s.describe(&level))
            .collect();
        assert!(
            uses.iter()
                .any(|u| u.starts_with("junction `x` connection")),
            "{uses:?}"
        );
        assert!(
            uses.iter().any(|u| u == "spawner `s` route `east`"),
            "{uses:?}"
        );
        assert!(
            uses.iter()
                .any(|u| u.starts_with("expectation `road_length_m")),
            "{uses:?}"
        );
        let through = junction
            .connections
            .iter()
            .filter(|c| c.to == "x east out" || c.from == "x east out")
            .count();
        assert!(through > 0);
        let letters = junction.signal.as_ref().expect("signal").phases[0]
            .state
            .len();
        e.apply(Command::DeleteRoad {
            road: road_index(&level, "x east out"),
        })
        .expect("deletes");
        let after = e.level();
        let j = &after.junctions[0];
        assert_eq!(j.connections.len(), junction.connections.len() - through);
        assert!(j.connections.iter().all(|c| c.to != "x east out"));
        // Each phase lost one letter per connection removed.
        for phase in &j.signal.as_ref().expect("signal").phases {
            assert_eq!(phase.state.len(), letters - through);
        }
        assert!(
            after.spawners[0].routes.is_empty(),
            "the route through it went"
        );
        assert_eq!(
            after.expect.len(),
            1,
            "the road's expectation went, the junction's stayed"
        );
        assert!(validate(after).is_empty(), "{:?}", validate(after));
        assert!(e.undo());
        assert_eq!(e.level(), &level);
    }

    #[test]
    fn renaming_a_road_and_a_junction_follows_every_reference_and_undoes() {
        let level = crossroads_level();
        let mut e = Editor::with_level(level.clone(), None);
        let r = road_index(&level, "x west in");
        let spec = level.roads[r].clone();
        e.apply(Command::SetRoad {
            road: r,
            name: "avenue".to_owned(),
            lanes: spec.lanes,
            lane_width_m: spec.lane_width_m,
            speed_limit_kmh: spec.speed_limit_kmh,
        })
        .expect("renames");
        let after = e.level();
        assert_eq!(after.spawners[0].road, "avenue");
        assert_eq!(after.spawners[0].routes[0].roads[0], "avenue");
        assert!(
            after.junctions[0]
                .connections
                .iter()
                .any(|c| c.from == "avenue")
        );
        assert!(references(after, &ItemRef::new(ItemKind::Road, "x west in")).is_empty());
        assert!(validate(after).is_empty(), "{:?}", validate(after));
        let mut j = after.junctions[0].clone();
        j.name = "plaza".to_owned();
        e.apply(Command::SetJunction(0, j))
            .expect("renames junction");
        assert_eq!(e.level().expect[1].qualifier.as_deref(), Some("plaza"));
        assert!(e.undo() && e.undo());
        assert_eq!(e.level(), &level);
    }

    #[test]
    fn deleting_a_junction_takes_its_expectations_and_a_used_profile_is_refused_with_its_users() {
        let level = crossroads_level();
        let mut e = Editor::with_level(level.clone(), None);
        e.apply(Command::DeleteJunction(0)).expect("deletes");
        assert!(e.level().junctions.is_empty());
        assert!(
            e.level()
                .expect
                .iter()
                .all(|x| x.metric != Metric::JunctionDelayS),
            "the junction's expectation went with it"
        );
        assert!(e.undo());
        let err = e
            .apply(Command::DeleteDriverProfile(0))
            .expect_err("a spawner uses it");
        assert!(
            matches!(&err, EditError::InUse { by, .. } if by == &["spawner `s`"]),
            "{err}"
        );
        assert!(err.to_string().contains("is used by spawner `s`"), "{err}");
        let err = e
            .apply(Command::DeleteVehicleType(0))
            .expect_err("a profile drives it");
        assert!(matches!(err, EditError::InUse { .. }), "{err}");
        assert_eq!(e.level(), &level, "refusals change nothing");
    }

    #[test]
    fn a_priority_junctions_major_road_goes_with_the_road() {
        let mut level = crossroads_level();
        level.junctions[0].control = Control::Priority {
            major: vec!["x west in".to_owned(), "x east in".to_owned()],
            stop: false,
        };
        level.junctions[0].signal = None;
        let mut e = Editor::with_level(level.clone(), None);
        e.apply(Command::DeleteRoad {
            road: road_index(&level, "x west in"),
        })
        .expect("deletes");
        let Control::Priority { major, .. } = &e.level().junctions[0].control else {
            panic!("priority kept");
        };
        assert_eq!(major, &["x east in"]);
        assert!(e.level().spawners.is_empty(), "the spawner on it went");
    }

    #[test]
    fn road_settings_are_held_to_the_schemas_limits() {
        let level = crossroads_level();
        let mut e = Editor::with_level(level.clone(), None);
        let spec = level.roads[0].clone();
        let set = |lanes, width, limit| Command::SetRoad {
            road: 0,
            name: spec.name.clone(),
            lanes,
            lane_width_m: width,
            speed_limit_kmh: limit,
        };
        // The widest values validation accepts are accepted here too.
        let (lanes, width, limit) = (*LANES.end(), *LANE_WIDTH_M.end(), *SPEED_LIMIT_KMH.end());
        e.apply(set(lanes, 6.0, limit))
            .expect("the most lanes, the highest limit");
        e.apply(set(1, width, limit)).expect("the widest lane");
        for bad in [
            set(lanes + 1, width, limit),
            set(1, *LANE_WIDTH_M.start() - 0.01, limit),
            set(1, width, *SPEED_LIMIT_KMH.end() + 1.0),
            set(1, f64::NAN, limit),
        ] {
            let err = e.apply(bad).expect_err("out of range");
            assert!(matches!(err, EditError::OutOfRange { .. }), "{err}");
        }
    }

    #[test]
    fn a_script_sets_fields_by_name_through_each_items_own_edit() {
        let level = crossroads_level();
        let mut e = Editor::with_level(level.clone(), None);
        let script = r#"[
            Set(item: Road("x west in"), field: "lanes", value: 2),
            Set(item: Junction("x"), field: "signal.phases.0.duration_s", value: 20.5),
            Set(item: Spawner("s"), field: "interval_s.min", value: 2.5),
            Set(item: Spawner("s"), field: "max_vehicles", value: 40),
            Set(item: Level, field: "seed", value: 99),
            Set(item: Level, field: "telemetry.period_s", value: 0.5),
            Set(item: Road("x east out"), field: "name", value: "boulevard"),
        ]"#;
        for command in crate::parse_script(script, std::path::Path::new("s.ron")).expect("parses") {
            e.apply(command).expect("applies");
        }
        let after = e.level();
        assert_eq!(after.road("x west in").expect("road").lanes, 2);
        let program = after.junctions[0].signal.as_ref().expect("signal");
        assert_eq!(program.phases[0].duration_s, 20.5);
        assert_eq!(after.spawners[0].interval_s.min, 2.5);
        assert_eq!(after.spawners[0].max_vehicles, Some(40));
        assert_eq!(after.seed, 99);
        assert_eq!(after.telemetry.period_s, 0.5);
        // A name set this way is followed like the inspector's.
        assert_eq!(after.spawners[0].routes[0].roads[1], "boulevard");
        assert_eq!(after.expect[0].qualifier.as_deref(), Some("boulevard"));
        assert!(validate(after).is_empty(), "{:?}", validate(after));
        for (bad, says) in [
            (
                r#"Set(item: Road("nowhere"), field: "lanes", value: 2)"#,
                "there is no road `nowhere`",
            ),
            (
                r#"Set(item: Road("x west in"), field: "lane", value: 2)"#,
                "unknown field `lane`",
            ),
            (
                r#"Set(item: Road("x west in"), field: "lanes", value: 40)"#,
                "lanes 40: expected 1 to 16",
            ),
            (
                r#"Set(item: Road("x west in"), field: "points.9.pos", value: (0, 0, 0))"#,
                "not an index",
            ),
            (
                r#"Set(item: Spawner("s"), field: "s_m", value: 5000)"#,
                "outside road",
            ),
            (
                r#"Set(item: Level, field: "roads", value: [])"#,
                "the level's settings are",
            ),
        ] {
            let command = crate::parse_script(&format!("[{bad}]"), std::path::Path::new("s.ron"))
                .expect("parses")
                .remove(0);
            let err = e.apply(command).expect_err(bad).to_string();
            assert!(err.contains(says), "{bad}: {err}");
        }
        assert_eq!(e.undo_label(), Some("set a field"));
    }

    /// The name of a command's kind. The match has no wildcard: a new kind of command does not
    /// compile until it is named here, and then the test below fails until it applies one.
    fn kind(c: &Command) -> &'static str {
        match c {
            Command::AddRoad { .. } => "AddRoad",
            Command::AppendPoint { .. } => "AppendPoint",
            Command::InsertPoint { .. } => "InsertPoint",
            Command::MovePoint { .. } => "MovePoint",
            Command::DeletePoint { .. } => "DeletePoint",
            Command::DeleteRoad { .. } => "DeleteRoad",
            Command::SetClosed { .. } => "SetClosed",
            Command::Connect { .. } => "Connect",
            Command::SetLinks { .. } => "SetLinks",
            Command::JoinEnd { .. } => "JoinEnd",
            Command::JoinSide { .. } => "JoinSide",
            Command::JoinExit { .. } => "JoinExit",
            Command::SetPoint { .. } => "SetPoint",
            Command::SetRoad { .. } => "SetRoad",
            Command::AddSpawner(_) => "AddSpawner",
            Command::SetSpawner(..) => "SetSpawner",
            Command::AddDestroyer(_) => "AddDestroyer",
            Command::SetDestroyer(..) => "SetDestroyer",
            Command::AddTrigger(_) => "AddTrigger",
            Command::SetTrigger(..) => "SetTrigger",
            Command::AddDetector(_) => "AddDetector",
            Command::SetDetector(..) => "SetDetector",
            Command::DeleteDetector(_) => "DeleteDetector",
            Command::MoveMarker { .. } => "MoveMarker",
            Command::DeleteMarker { .. } => "DeleteMarker",
            Command::SetLevelInfo { .. } => "SetLevelInfo",
            Command::AddVehicleType(_) => "AddVehicleType",
            Command::SetVehicleType(..) => "SetVehicleType",
            Command::DeleteVehicleType(_) => "DeleteVehicleType",
            Command::AddDriverProfile(_) => "AddDriverProfile",
            Command::SetDriverProfile(..) => "SetDriverProfile",
            Command::DeleteDriverProfile(_) => "DeleteDriverProfile",
            Command::SetExpectations(_) => "SetExpectations",
            Command::AddVehicles(_) => "AddVehicles",
            Command::SetVehicles(..) => "SetVehicles",
            Command::DeleteVehicles(_) => "DeleteVehicles",
            Command::AddPrefab { .. } => "AddPrefab",
            Command::SetJunction(..) => "SetJunction",
            Command::DeleteJunction(_) => "DeleteJunction",
            Command::Set { .. } => "Set",
            Command::Batch { .. } => "Batch",
        }
    }

    /// One edit of the sequence below, made from the editor's state when its turn comes.
    type Step<'a> = Box<dyn Fn(&Editor) -> Command + 'a>;

    #[test]
    fn every_kind_of_command_applies_and_undoes_to_the_exact_level_before_it() {
        use flockway_level::{
            DestroyerSpec, DetectorSpec, InitialVehiclesSpec, TriggerEffectSpec, TriggerSpec,
            VehicleTypeSpec,
        };
        let p = |x: f64, y: f64| DVec3::new(x, y, 0.0);
        let mut level = crossroads_level();
        for (name, a, b) in [
            ("main", p(0.0, 1000.0), p(1000.0, 1000.0)),
            ("ramp", p(0.0, 900.0), p(150.0, 980.0)),
            ("exit", p(720.0, 990.0), p(850.0, 900.0)),
            ("a", p(0.0, 1500.0), p(100.0, 1500.0)),
            ("b", p(110.0, 1500.0), p(300.0, 1500.0)),
        ] {
            level.roads.push(RoadSpec::through(name, 1, 50.0, &[a, b]));
        }
        let mut e = Editor::with_level(level.clone(), None);
        let n = level.roads.len();
        let index = |e: &Editor, name: &str| road_index(e.level(), name);
        let mut spawner = level.spawners[0].clone();
        spawner.name = "s2".to_owned();
        let mut slower = spawner.clone();
        slower.interval_s.min = 2.5;
        let destroyer = DestroyerSpec {
            name: "d".to_owned(),
            place: DestroyerPlaceSpec::OnRoad {
                road: "x east out".to_owned(),
                s_m: 80.0,
            },
            arrivals_only: false,
        };
        let trigger = TriggerSpec {
            name: "t".to_owned(),
            road: "x east out".to_owned(),
            from_m: 10.0,
            to_m: 30.0,
            lanes: None,
            effect: TriggerEffectSpec::SpeedLimit { kmh: 30.0 },
        };
        let detector = DetectorSpec {
            name: "loop".to_owned(),
            road: "x east out".to_owned(),
            s_m: 50.0,
            lanes: None,
            period_s: 30.0,
        };
        let vehicle_type = VehicleTypeSpec {
            name: "sedan 2".to_owned(),
            path: level.vehicle_types[0].path.clone(),
        };
        let mut profile = level.driver_profiles[0].clone();
        profile.name = "p2".to_owned();
        let group = InitialVehiclesSpec {
            road: "x east out".to_owned(),
            lane: 0,
            count: 2,
            profile: level.driver_profiles[0].name.clone(),
            from_m: 40.0,
            to_m: Some(80.0),
            speed_kmh: None,
            jitter_m: 0.0,
        };
        let prefab = flockway_level::roundabout("r", p(3000.0, 3000.0));
        let mut plaza = level.junctions[0].clone();
        plaza.name = "plaza".to_owned();
        let info = Command::SetLevelInfo {
            name: "renamed".to_owned(),
            description: "edited".to_owned(),
            seed: 5,
            duration_s: 90.0,
            telemetry: level.telemetry.clone(),
        };
        // Built as it goes, as the editor's user would: each may name what an earlier one made.
        let steps: Vec<Step<'_>> = vec![
            Box::new(|_| Command::AddRoad { at: p(0.0, -500.0) }),
            Box::new(move |_| Command::AppendPoint {
                road: n,
                at: p(200.0, -500.0),
            }),
            Box::new(move |_| Command::InsertPoint {
                road: n,
                index: 1,
                at: p(100.0, -510.0),
            }),
            Box::new(move |_| Command::MovePoint {
                road: n,
                index: 1,
                to: p(100.0, -505.0),
            }),
            Box::new(move |_| Command::DeletePoint { road: n, index: 1 }),
            Box::new(move |_| Command::SetPoint {
                road: n,
                index: 0,
                point: ControlPoint {
                    bank_deg: 1.0,
                    ..ControlPoint::at(p(0.0, -500.0))
                },
            }),
            Box::new(move |_| Command::SetClosed {
                road: n,
                closed: true,
            }),
            Box::new(move |_| Command::Connect {
                road: n,
                next: Some("b".to_owned()),
            }),
            Box::new(move |_| Command::SetLinks {
                road: n,
                links: Vec::new(),
            }),
            Box::new(move |_| Command::DeleteRoad { road: n }),
            Box::new(move |e| Command::JoinEnd {
                road: index(e, "a"),
                onto: "b".to_owned(),
            }),
            Box::new(move |e| Command::JoinSide {
                road: index(e, "ramp"),
                onto: "main".to_owned(),
                s_m: 200.0,
            }),
            Box::new(move |e| Command::JoinExit {
                road: index(e, "exit"),
                onto: "main on".to_owned(),
                s_m: 300.0,
            }),
            Box::new(move |e| {
                let r = index(e, "b");
                Command::SetRoad {
                    road: r,
                    name: "bee".to_owned(),
                    lanes: 1,
                    lane_width_m: 3.0,
                    speed_limit_kmh: 60.0,
                }
            }),
            Box::new(move |_| Command::AddSpawner(spawner.clone())),
            Box::new(move |_| Command::SetSpawner(1, slower.clone())),
            Box::new(move |_| Command::AddDestroyer(destroyer.clone())),
            Box::new(|e| {
                let mut d = e.level().destroyers[0].clone();
                d.name = "gate".to_owned();
                Command::SetDestroyer(0, d)
            }),
            Box::new(move |_| Command::AddTrigger(trigger.clone())),
            Box::new(|e| {
                let mut t = e.level().triggers[0].clone();
                t.effect = TriggerEffectSpec::SpeedLimit { kmh: 40.0 };
                Command::SetTrigger(0, t)
            }),
            Box::new(move |_| Command::AddDetector(detector.clone())),
            Box::new(|e| {
                let mut d = e.level().detectors[0].clone();
                d.lanes = Some(vec![0]);
                Command::SetDetector(0, d)
            }),
            Box::new(|_| Command::DeleteDetector(0)),
            Box::new(|_| Command::MoveMarker {
                kind: MarkerKind::Trigger,
                index: 0,
                s_m: 12.0,
            }),
            Box::new(|_| Command::DeleteMarker {
                kind: MarkerKind::Trigger,
                index: 0,
            }),
            Box::new(move |_| info.clone()),
            Box::new(move |_| Command::AddVehicleType(vehicle_type.clone())),
            Box::new(|e| {
                let last = e.level().vehicle_types.len() - 1;
                let mut v = e.level().vehicle_types[last].clone();
                v.name = "sedan 3".to_owned();
                Command::SetVehicleType(last, v)
            }),
            Box::new(|e| Command::DeleteVehicleType(e.level().vehicle_types.len() - 1)),
            Box::new(move |_| Command::AddDriverProfile(profile.clone())),
            Box::new(|e| {
                let last = e.level().driver_profiles.len() - 1;
                let mut v = e.level().driver_profiles[last].clone();
                v.name = "p3".to_owned();
                Command::SetDriverProfile(last, v)
            }),
            Box::new(|e| Command::DeleteDriverProfile(e.level().driver_profiles.len() - 1)),
            Box::new(|e| Command::SetExpectations(e.level().expect[..1].to_vec())),
            Box::new(move |_| Command::AddVehicles(group.clone())),
            Box::new(|e| {
                let mut g = e.level().vehicles[0].clone();
                g.count = 3;
                Command::SetVehicles(0, g)
            }),
            Box::new(|_| Command::DeleteVehicles(0)),
            Box::new(move |_| Command::AddPrefab {
                roads: prefab.roads.clone(),
                junctions: prefab.junctions.clone(),
            }),
            Box::new(move |_| Command::SetJunction(0, plaza.clone())),
            Box::new(|e| Command::DeleteJunction(e.level().junctions.len() - 1)),
            Box::new(|_| Command::Set {
                item: Target::Level,
                field: "duration_s".to_owned(),
                value: ron::Value::Number(ron::Number::F64(120.0.into())),
            }),
            Box::new(|_| Command::Batch {
                label: "two seeds".to_owned(),
                commands: vec![
                    Command::Set {
                        item: Target::Level,
                        field: "seed".to_owned(),
                        value: ron::Value::Number(ron::Number::U64(8)),
                    },
                    Command::Set {
                        item: Target::Level,
                        field: "seed".to_owned(),
                        value: ron::Value::Number(ron::Number::U64(9)),
                    },
                ],
            }),
        ];
        let mut before = Vec::new();
        let mut kinds = std::collections::BTreeSet::new();
        for step in &steps {
            let command = step(&e);
            kinds.insert(kind(&command));
            before.push(e.level().clone());
            let label = command.label().to_owned();
            e.apply(command)
                .unwrap_or_else(|err| panic!("{label}: {err}"));
            assert!(
                e.level() != before.last().expect("pushed"),
                "{label} changed nothing"
            );
        }
        assert!(validate(e.level()).is_empty(), "{:?}", validate(e.level()));
        let all: Vec<&str> = kinds.iter().copied().collect();
        assert_eq!(all.len(), 41, "one of every kind: {all:?}");
        while let Some(level) = before.pop() {
            let label = e.undo_label().unwrap_or_default().to_owned();
            assert!(e.undo());
            assert!(e.level() == &level, "undo of {label}");
        }
        assert!(!e.undo());
    }
}
