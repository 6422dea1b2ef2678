//! Roads in the ECS world: components the editor changes, and the network every system queries.

use crate::{RoadError, RoadGeometry, RoadMeshes, RoadProjection, RoadSpec};
use bevy_ecs::prelude::*;
use flockway_core::{Sim, SimPlugin, StepSet};
use glam::DVec3;
use std::collections::BTreeMap;
use std::sync::Arc;

/// Largest gap allowed between a road's end and the start of the road it leads onto, in metres.
pub const MAX_CONNECTION_GAP_M: f64 = 1.0;

/// A road's index in the level's road list: stable for the whole run.
#[derive(Component, Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct RoadId(pub u32);

/// A road as the user defines it. Change it and its geometry and meshes are rebuilt before the
/// next step.
#[derive(Component, Debug, Clone, PartialEq)]
pub struct Road(pub RoadSpec);

/// A road's derived geometry and meshes, kept in step with its [`Road`].
#[derive(Component, Debug, Clone)]
pub struct RoadShape {
    /// Geometry for queries.
    pub geometry: Arc<RoadGeometry>,
    /// Meshes for physics and rendering.
    pub meshes: Arc<RoadMeshes>,
}

/// A problem that stops the road network from being built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NetworkError {
    /// A road's spec is not drivable.
    #[error(transparent)]
    Road(#[from] RoadError),
    /// Two roads share a name.
    #[error("two roads are named `{0}`; road names must be unique")]
    DuplicateName(String),
    /// `next` names a road that does not exist.
    #[error("road `{road}` leads onto `{next}`, but there is no road of that name")]
    UnknownNext {
        /// The road with the connection.
        road: String,
        /// The missing name.
        next: String,
    },
    /// `next` names a road whose start is not at this road's end.
    #[error(
        "road `{road}` ends {gap_m:.2} m from the start of `{next}`; a connection needs them within 1 m"
    )]
    Gap {
        /// The road with the connection.
        road: String,
        /// The road it leads onto.
        next: String,
        /// The gap.
        gap_m: f64,
    },
}

/// Every road of the world, indexed by [`RoadId`], with connections resolved.
#[derive(Resource, Debug, Clone, Default)]
pub struct RoadNetwork {
    /// Indexed by `RoadId`; an id whose road was deleted in the editor leaves a hole.
    slots: Vec<Option<Slot>>,
    by_name: BTreeMap<String, RoadId>,
}

#[derive(Debug, Clone)]
struct Slot {
    geometry: Arc<RoadGeometry>,
    meshes: Arc<RoadMeshes>,
    next: Option<RoadId>,
}

impl RoadNetwork {
    /// Builds a network from specs (road `i` gets id `i`), checking names and connections.
    pub fn build(specs: &[RoadSpec]) -> Result<RoadNetwork, NetworkError> {
        let shapes = specs
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let g = Arc::new(RoadGeometry::new(s)?);
                let m = Arc::new(RoadMeshes::build(&g));
                Ok((RoadId(i as u32), g, m))
            })
            .collect::<Result<Vec<_>, RoadError>>()?;
        RoadNetwork::from_shapes(shapes)
    }

    fn from_shapes(
        shapes: Vec<(RoadId, Arc<RoadGeometry>, Arc<RoadMeshes>)>,
    ) -> Result<RoadNetwork, NetworkError> {
        let mut by_name = BTreeMap::new();
        for (id, g, _) in &shapes {
            if by_name.insert(g.name().to_owned(), *id).is_some() {
                return Err(NetworkError::DuplicateName(g.name().to_owned()));
            }
        }
        let len = shapes
            .iter()
            .map(|(id, _, _)| id.0 as usize + 1)
            .max()
            .unwrap_or(0);
        let mut slots: Vec<Option<Slot>> = vec![None; len];
        for (id, geometry, meshes) in shapes {
            slots[id.0 as usize] = Some(Slot {
                geometry,
                meshes,
                next: None,
            });
        }
        let mut resolved = Vec::new();
        for (i, slot) in slots.iter().enumerate() {
            let Some(slot) = slot else { continue };
            let g = &slot.geometry;
            let Some(name) = &g.spec().next else { continue };
            let Some(&id) = by_name.get(name) else {
                return Err(NetworkError::UnknownNext {
                    road: g.name().to_owned(),
                    next: name.clone(),
                });
            };
            let start = slots[id.0 as usize]
                .as_ref()
                .map(|s| s.geometry.pos_at(0.0))
                .unwrap_or(DVec3::INFINITY);
            let gap_m = (start - g.pos_at(g.length_m())).length();
            if gap_m > MAX_CONNECTION_GAP_M {
                return Err(NetworkError::Gap {
                    road: g.name().to_owned(),
                    next: name.clone(),
                    gap_m,
                });
            }
            resolved.push((i, id));
        }
        for (i, id) in resolved {
            if let Some(slot) = &mut slots[i] {
                slot.next = Some(id);
            }
        }
        Ok(RoadNetwork { slots, by_name })
    }

    /// Number of roads.
    pub fn len(&self) -> usize {
        self.slots.iter().flatten().count()
    }

    /// Whether there are no roads.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The road with this id.
    pub fn get(&self, id: RoadId) -> Option<&Arc<RoadGeometry>> {
        self.slot(id).map(|s| &s.geometry)
    }

    /// The meshes of the road with this id.
    pub fn meshes(&self, id: RoadId) -> Option<&Arc<RoadMeshes>> {
        self.slot(id).map(|s| &s.meshes)
    }

    fn slot(&self, id: RoadId) -> Option<&Slot> {
        self.slots.get(id.0 as usize).and_then(Option::as_ref)
    }

    /// The id of the road with this name.
    pub fn id(&self, name: &str) -> Option<RoadId> {
        self.by_name.get(name).copied()
    }

    /// Every road with its id, in id order.
    pub fn iter(&self) -> impl Iterator<Item = (RoadId, &Arc<RoadGeometry>)> {
        self.slots
            .iter()
            .enumerate()
            .filter_map(|(i, s)| s.as_ref().map(|s| (RoadId(i as u32), &s.geometry)))
    }

    /// The road traffic continues onto after the end of `id`.
    pub fn next(&self, id: RoadId) -> Option<RoadId> {
        self.slot(id).and_then(|s| s.next)
    }

    /// Moves `ds_m` metres along the direction of travel from arc position `s_m` on road `id`,
    /// following connections and wrapping around loops. `None` if that runs off an open end.
    pub fn advance(&self, id: RoadId, s_m: f64, ds_m: f64) -> Option<(RoadId, f64)> {
        let mut road = id;
        let mut s = s_m + ds_m;
        // Bounded: a chain of connections longer than the road count would be a cycle.
        for _ in 0..=self.slots.len() {
            let g = self.get(road)?;
            if g.is_closed() {
                return Some((road, g.normalize_s(s)));
            }
            if s < 0.0 {
                return None;
            }
            if s <= g.length_m() {
                return Some((road, s));
            }
            s -= g.length_m();
            road = self.next(road)?;
        }
        None
    }

    /// The road closest to a world position and where on it the position lies.
    pub fn project(&self, pos: DVec3) -> Option<(RoadId, RoadProjection)> {
        self.iter()
            .map(|(id, g)| (id, g.project(pos)))
            // Ties go to the lower id, so the answer never depends on anything but the data.
            .min_by(|a, b| {
                a.1.distance_m
                    .total_cmp(&b.1.distance_m)
                    .then(a.0.cmp(&b.0))
            })
    }
}

/// Why the road network is out of date: the last edit made it invalid.
#[derive(Resource, Debug, Clone, Default, PartialEq)]
pub struct RoadNetworkError(pub Option<NetworkError>);

/// Keeps [`RoadShape`]s and the [`RoadNetwork`] in step with the [`Road`] components.
pub struct RoadPlugin;

impl SimPlugin for RoadPlugin {
    fn build(&self, sim: &mut Sim) {
        sim.world_mut().init_resource::<RoadNetwork>();
        sim.world_mut().init_resource::<RoadNetworkError>();
        sim.add_systems(StepSet::Prepare, rebuild_roads);
    }
}

/// Rebuilds the shapes of edited roads and then the network. An invalid edit leaves the last
/// good network in place and reports why in [`RoadNetworkError`].
pub fn rebuild_roads(
    mut commands: Commands,
    roads: Query<(Entity, &RoadId, Ref<Road>, Option<&RoadShape>)>,
    mut removed: RemovedComponents<Road>,
    mut network: ResMut<RoadNetwork>,
    mut error: ResMut<RoadNetworkError>,
) {
    let removed_any = removed.read().count() > 0;
    if !removed_any && !roads.iter().any(|(_, _, road, _)| road.is_changed()) {
        return;
    }
    let mut sorted: Vec<_> = roads.iter().collect();
    sorted.sort_by_key(|(_, id, _, _)| **id);
    let mut shapes = Vec::with_capacity(sorted.len());
    for (entity, id, road, shape) in sorted {
        let (geometry, meshes) = match shape {
            Some(shape) if !road.is_changed() => (shape.geometry.clone(), shape.meshes.clone()),
            _ => match RoadGeometry::new(&road.0) {
                Ok(g) => {
                    let geometry = Arc::new(g);
                    let meshes = Arc::new(RoadMeshes::build(&geometry));
                    commands.entity(entity).insert(RoadShape {
                        geometry: geometry.clone(),
                        meshes: meshes.clone(),
                    });
                    (geometry, meshes)
                }
                Err(e) => {
                    error.0 = Some(e.into());
                    return;
                }
            },
        };
        shapes.push((*id, geometry, meshes));
    }
    match RoadNetwork::from_shapes(shapes) {
        Ok(n) => {
            *network = n;
            error.0 = None;
        }
        Err(e) => error.0 = Some(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sim_with(specs: &[RoadSpec]) -> Sim {
        let mut sim = Sim::new(1);
        sim.add_plugin(RoadPlugin);
        for (i, s) in specs.iter().enumerate() {
            sim.world_mut().spawn((RoadId(i as u32), Road(s.clone())));
        }
        sim.prepare().expect("schedule builds");
        sim
    }

    #[test]
    fn the_network_follows_edits_to_road_components() {
        let a = RoadSpec::through("a", 2, 60.0, &[DVec3::ZERO, DVec3::new(100.0, 0.0, 0.0)]);
        let mut sim = sim_with(&[a]);
        sim.step();
        let len = |sim: &Sim| {
            sim.world()
                .resource::<RoadNetwork>()
                .get(RoadId(0))
                .map(|g| g.length_m())
        };
        assert!((len(&sim).expect("built") - 100.0).abs() < 1e-9);

        // Move the end point: the shape and the network are rebuilt before the next step.
        let mut q = sim.world_mut().query::<&mut Road>();
        for mut road in q.iter_mut(sim.world_mut()) {
            road.0.points[1].pos.x = 250.0;
        }
        sim.step();
        assert!((len(&sim).expect("rebuilt") - 250.0).abs() < 1e-9);
        let mut shapes = sim.world_mut().query::<&RoadShape>();
        assert!(
            shapes
                .iter(sim.world())
                .all(|s| (s.geometry.length_m() - 250.0).abs() < 1e-9)
        );

        // An invalid edit keeps the last good network and says why.
        for mut road in q.iter_mut(sim.world_mut()) {
            road.0.lanes = 0;
        }
        sim.step();
        assert!((len(&sim).expect("kept") - 250.0).abs() < 1e-9);
        assert!(matches!(
            sim.world().resource::<RoadNetworkError>().0,
            Some(NetworkError::Road(RoadError::Lanes { .. }))
        ));
    }

    #[test]
    fn deleting_a_road_leaves_a_hole_not_a_shift() {
        let a = RoadSpec::through("a", 1, 60.0, &[DVec3::ZERO, DVec3::new(100.0, 0.0, 0.0)]);
        let b = RoadSpec::through(
            "b",
            1,
            60.0,
            &[DVec3::new(0.0, 50.0, 0.0), DVec3::new(100.0, 50.0, 0.0)],
        );
        let mut sim = sim_with(&[a, b]);
        sim.step();
        let mut q = sim.world_mut().query::<(Entity, &RoadId)>();
        let first = q
            .iter(sim.world())
            .find(|(_, id)| id.0 == 0)
            .map(|(e, _)| e)
            .expect("road 0");
        sim.world_mut().despawn(first);
        sim.step();
        let net = sim.world().resource::<RoadNetwork>();
        assert!(net.get(RoadId(0)).is_none());
        assert_eq!(
            net.get(RoadId(1)).map(|g| g.name().to_owned()),
            Some("b".to_owned())
        );
        assert_eq!(net.id("b"), Some(RoadId(1)));
        assert_eq!(net.len(), 1);
    }
}
