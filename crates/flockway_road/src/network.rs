//! Roads in the ECS world: components the editor changes, and the network every system queries.

use crate::junction::{Junction, JunctionError, JunctionSpec};
use crate::{RoadError, RoadGeometry, RoadMeshes, RoadProjection, RoadSpec};
use bevy_ecs::prelude::*;
use flockway_core::{Sim, SimPlugin, StepSet};
use glam::DVec3;
use std::cmp::Reverse;
use std::collections::{BTreeMap, BinaryHeap};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

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
    /// Two junctions share a name.
    #[error("two junctions are named `{0}`; junction names must be unique")]
    DuplicateJunction(String),
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
    /// A link names a lane that one of its roads does not have.
    #[error(
        "road `{road}` links its lane {from_lane} onto lane {to_lane} of `{next}`, but {which} has {lanes} lane(s), numbered 0 to {last}",
        last = lanes.saturating_sub(1)
    )]
    LinkLane {
        /// The road with the link.
        road: String,
        /// The road it leads onto.
        next: String,
        /// Lane here.
        from_lane: u32,
        /// Lane there.
        to_lane: u32,
        /// Which road lacks the lane (`this road` or the other's name in backticks).
        which: String,
        /// That road's lane count.
        lanes: u32,
    },
    /// A road links onto the same road twice.
    #[error(
        "road `{road}` links onto `{next}` more than once; give all its lane pairs in one link"
    )]
    DuplicateLink {
        /// The road with the links.
        road: String,
        /// The road it leads onto twice.
        next: String,
    },
    /// A lane pair of a link does not meet: the lanes' centres are apart.
    #[error(
        "road `{road}` lane {from_lane} ends {gap_m:.2} m from the start of lane {to_lane} of `{next}`; linked lanes must meet within 1 m"
    )]
    LaneGap {
        /// The road with the link.
        road: String,
        /// The road it leads onto.
        next: String,
        /// Lane here.
        from_lane: u32,
        /// Lane there.
        to_lane: u32,
        /// Distance between the lane centres, m.
        gap_m: f64,
    },
    /// A junction that cannot be built.
    #[error(transparent)]
    Junction(#[from] JunctionError),
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
    /// The junctions, in the level's order; their paths are roads after the level's own.
    junctions: Vec<Junction>,
    /// Per junction, its paths' roads in connection order.
    path_roads: Vec<Vec<RoadId>>,
    /// Pairs of roads that cross without meeting (a bridge), smaller id first, sorted.
    crossings: Vec<(RoadId, RoadId)>,
    /// Which build this is ([`revision`](Self::revision)).
    revision: u64,
}

/// The revision the next network built gets (0 is the empty default network's).
static NEXT_REVISION: AtomicU64 = AtomicU64::new(1);

/// The junction path a vehicle is about to enter ([`RoadNetwork::junction_ahead`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JunctionAhead {
    /// The junction's index.
    pub junction: usize,
    /// The path's index in the junction.
    pub path: usize,
    /// From the vehicle's front bumper to the line (the end of its road), m.
    pub to_line_m: f64,
}

/// A link at a road's end onto the start of another road, lane by lane.
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    /// The road it leads onto.
    pub to: RoadId,
    /// `(lane here, lane there)` pairs, sorted.
    pub lanes: Vec<(u32, u32)>,
}

impl Link {
    /// The lane of the other road that `lane` leads onto, if it leads onto one.
    pub fn lane_to(&self, lane: u32) -> Option<u32> {
        self.lanes.iter().find(|(a, _)| *a == lane).map(|(_, b)| *b)
    }
}

#[derive(Debug, Clone)]
struct Slot {
    geometry: Arc<RoadGeometry>,
    meshes: Arc<RoadMeshes>,
    links: Vec<Link>,
    /// Per lane of this road: the `(road, lane)` pairs that lead onto it.
    incoming: Vec<Vec<(RoadId, u32)>>,
    /// If the road is a path through a junction: the junction's index and the path's.
    path: Option<(usize, usize)>,
}

/// How far ahead, in metres, a route is read for which lanes lead on along it.
pub const LANE_REACH_HORIZON_M: f64 = 3_000.0;

impl RoadNetwork {
    /// Builds a network from specs (road `i` gets id `i`), checking names and connections.
    pub fn build(specs: &[RoadSpec]) -> Result<RoadNetwork, NetworkError> {
        RoadNetwork::build_with(specs, &[])
    }

    /// Builds a network from road specs (road `i` gets id `i`) and junctions, whose paths get
    /// the ids after the roads', checking names, connections and junctions.
    pub fn build_with(
        specs: &[RoadSpec],
        junctions: &[JunctionSpec],
    ) -> Result<RoadNetwork, NetworkError> {
        let shapes = specs
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let g = Arc::new(RoadGeometry::new(s)?);
                let m = Arc::new(RoadMeshes::build(&g));
                Ok((RoadId(i as u32), g, m))
            })
            .collect::<Result<Vec<_>, RoadError>>()?;
        RoadNetwork::from_shapes(shapes, junctions)
    }

    fn from_shapes(
        mut shapes: Vec<(RoadId, Arc<RoadGeometry>, Arc<RoadMeshes>)>,
        junction_specs: &[JunctionSpec],
    ) -> Result<RoadNetwork, NetworkError> {
        // Junction paths become roads numbered after the level's, linked in and out below.
        let mut junctions = Vec::with_capacity(junction_specs.len());
        let mut paths = BTreeMap::new();
        let mut path_roads = vec![Vec::new(); junction_specs.len()];
        let mut path_links = Vec::new();
        let mut next_id = shapes.iter().map(|(id, _, _)| id.0 + 1).max().unwrap_or(0);
        // The level's roads by name (the first of a name, as a search would find it), for the
        // junctions' connections: a city has thousands.
        let mut named: BTreeMap<String, (u32, Arc<RoadGeometry>)> = BTreeMap::new();
        for (id, g, _) in &shapes {
            named
                .entry(g.name().to_owned())
                .or_insert_with(|| (id.0, Arc::clone(g)));
        }
        let mut junction_names = std::collections::BTreeSet::new();
        for (j, spec) in junction_specs.iter().enumerate() {
            if !junction_names.insert(spec.name.as_str()) {
                return Err(NetworkError::DuplicateJunction(spec.name.clone()));
            }
            let junction = Junction::build(spec, |name| {
                named.get(name).map(|(id, g)| (*id, g.as_ref()))
            })?;
            let mut built = Vec::with_capacity(junction.paths.len());
            for (k, path) in junction.paths.iter().enumerate() {
                let g = Arc::new(RoadGeometry::new(&path.spec)?);
                // A path is paved but not painted: its edge lines would criss-cross the junction.
                let m = Arc::new(RoadMeshes {
                    markings: crate::Mesh::default(),
                    ..RoadMeshes::build(&g)
                });
                let id = RoadId(next_id);
                next_id += 1;
                paths.insert(id, (j, k));
                path_roads[j].push(id);
                path_links.push((RoadId(path.from.0), path.from.1, id, path.to));
                built.push((id, g, m));
            }
            shapes.extend(built);
            junctions.push(junction);
        }
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
            let lanes = geometry.lanes() as usize;
            slots[id.0 as usize] = Some(Slot {
                geometry,
                meshes,
                links: Vec::new(),
                incoming: vec![Vec::new(); lanes],
                path: paths.get(&id).copied(),
            });
        }
        let mut resolved = Vec::new();
        for (i, slot) in slots.iter().enumerate() {
            let Some(slot) = slot else { continue };
            let g = &slot.geometry;
            let mut links: Vec<Link> = Vec::new();
            for spec in g.spec().outgoing() {
                let Some(&id) = by_name.get(&spec.to) else {
                    return Err(NetworkError::UnknownNext {
                        road: g.name().to_owned(),
                        next: spec.to.clone(),
                    });
                };
                if links.iter().any(|l| l.to == id) {
                    return Err(NetworkError::DuplicateLink {
                        road: g.name().to_owned(),
                        next: spec.to.clone(),
                    });
                }
                let Some(g2) = slots[id.0 as usize].as_ref().map(|s| &s.geometry) else {
                    continue;
                };
                let mut lanes = spec.lane_pairs(g.lanes(), g2.lanes());
                lanes.sort_unstable();
                lanes.dedup();
                for &(a, b) in &lanes {
                    let (which, n) = if a >= g.lanes() {
                        ("this road".to_owned(), g.lanes())
                    } else if b >= g2.lanes() {
                        (format!("`{}`", g2.name()), g2.lanes())
                    } else {
                        continue;
                    };
                    return Err(NetworkError::LinkLane {
                        road: g.name().to_owned(),
                        next: spec.to.clone(),
                        from_lane: a,
                        to_lane: b,
                        which,
                        lanes: n,
                    });
                }
                if spec.lanes.is_empty() {
                    // By position: the centre lines meet (roads of different widths may link).
                    let gap_m = (g2.pos_at(0.0) - g.pos_at(g.length_m())).length();
                    if gap_m > MAX_CONNECTION_GAP_M {
                        return Err(NetworkError::Gap {
                            road: g.name().to_owned(),
                            next: spec.to.clone(),
                            gap_m,
                        });
                    }
                } else {
                    for &(a, b) in &lanes {
                        let gap_m =
                            (g2.lane_point(b, 0.0) - g.lane_point(a, g.length_m())).length();
                        if gap_m > MAX_CONNECTION_GAP_M {
                            return Err(NetworkError::LaneGap {
                                road: g.name().to_owned(),
                                next: spec.to.clone(),
                                from_lane: a,
                                to_lane: b,
                                gap_m,
                            });
                        }
                    }
                }
                links.push(Link { to: id, lanes });
            }
            resolved.push((i, links));
        }
        for (from, lane, path, (to, to_lane)) in path_links {
            if let Some((_, links)) = resolved.iter_mut().find(|(i, _)| *i == from.0 as usize) {
                links.push(Link {
                    to: path,
                    lanes: vec![(lane, 0)],
                });
            }
            if let Some((_, links)) = resolved.iter_mut().find(|(i, _)| *i == path.0 as usize) {
                links.push(Link {
                    to: RoadId(to),
                    lanes: vec![(0, to_lane)],
                });
            }
        }
        for (i, links) in resolved {
            for link in &links {
                if let Some(to) = &mut slots[link.to.0 as usize] {
                    for &(a, b) in &link.lanes {
                        to.incoming[b as usize].push((RoadId(i as u32), a));
                    }
                }
            }
            if let Some(slot) = &mut slots[i] {
                slot.links = links;
            }
        }
        let crossings = crossings_of(&slots, &junctions, &path_roads);
        Ok(RoadNetwork {
            slots,
            by_name,
            junctions,
            path_roads,
            crossings,
            revision: NEXT_REVISION.fetch_add(1, Ordering::Relaxed),
        })
    }

    /// Tells one build of a network from another (a clone keeps it): what is worked out from
    /// a network once can be kept while this stays the same. Never reaches any output.
    pub fn revision(&self) -> u64 {
        self.revision
    }

    /// Pairs of roads whose centre lines cross where no junction or link joins them (a bridge,
    /// or a bridge netconvert drew flat): cars on the one pass cars on the other without
    /// touching. Smaller id first, sorted.
    pub fn crossings(&self) -> &[(RoadId, RoadId)] {
        &self.crossings
    }

    /// The junctions, in the level's order.
    pub fn junctions(&self) -> &[Junction] {
        &self.junctions
    }

    /// If road `id` is a path through a junction: the junction's index and the path's.
    pub fn junction_path(&self, id: RoadId) -> Option<(usize, usize)> {
        self.slot(id).and_then(|s| s.path)
    }

    /// The junction path that takes traffic from the end of `from` onto `to`, if one does
    /// (the first, by lane, when several lanes have one).
    pub fn junction_path_between(&self, from: RoadId, to: RoadId) -> Option<RoadId> {
        self.links(from)
            .iter()
            .map(|l| l.to)
            .find(|&p| self.junction_path(p).is_some() && self.link(p, to).is_some())
    }

    /// The road of path `k` of junction `j`.
    pub fn path_road(&self, j: usize, k: usize) -> Option<RoadId> {
        self.path_roads.get(j)?.get(k).copied()
    }

    /// The junction path a vehicle on `road`, lane `lane`, at `s_m`, bound for `next` (or
    /// following its lane's first link when `None`) is about to enter: the junction's index, the
    /// path's, and how far its front bumper (`half_length_m` ahead of `s_m`) is from the line.
    pub fn junction_ahead(
        &self,
        road: RoadId,
        lane: u32,
        s_m: f64,
        next: Option<RoadId>,
        half_length_m: f64,
    ) -> Option<JunctionAhead> {
        let next = next.or_else(|| self.lane_next(road, lane, None).map(|(r, _)| r))?;
        let (junction, path) = self.junction_path(next)?;
        let g = self.get(road)?;
        Some(JunctionAhead {
            junction,
            path,
            to_line_m: g.length_m() - s_m - half_length_m,
        })
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

    /// Whether this network was built from exactly these level roads (in id order) and
    /// junctions: the same ids with equal specs, and no other road but the junctions' paths.
    pub fn is_built_from<'a>(
        &self,
        roads: impl IntoIterator<Item = (RoadId, &'a RoadSpec)>,
        junctions: &[JunctionSpec],
    ) -> bool {
        let mut roads = roads.into_iter();
        let own = self.slots.iter().enumerate().filter_map(|(i, s)| {
            s.as_ref()
                .filter(|s| s.path.is_none())
                .map(|s| (RoadId(i as u32), s.geometry.spec()))
        });
        for (id, spec) in own {
            if !roads.next().is_some_and(|(i, s)| i == id && s == spec) {
                return false;
            }
        }
        self.revision != 0
            && roads.next().is_none()
            && self.junctions.iter().map(|j| &j.spec).eq(junctions)
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

    /// The first road traffic continues onto after the end of `id` (its `next`, or its first
    /// link).
    pub fn next(&self, id: RoadId) -> Option<RoadId> {
        self.slot(id).and_then(|s| s.links.first()).map(|l| l.to)
    }

    /// The links at the end of road `id`, in the order the level gives them.
    pub fn links(&self, id: RoadId) -> &[Link] {
        self.slot(id).map_or(&[], |s| s.links.as_slice())
    }

    /// The link from the end of `from` onto `to`, if there is one.
    pub fn link(&self, from: RoadId, to: RoadId) -> Option<&Link> {
        self.links(from).iter().find(|l| l.to == to)
    }

    /// Where lane `lane` of road `id` leads at the road's end: onto `prefer` if that lane links
    /// there, otherwise along the first link that takes the lane. `None` if the lane ends.
    pub fn lane_next(
        &self,
        id: RoadId,
        lane: u32,
        prefer: Option<RoadId>,
    ) -> Option<(RoadId, u32)> {
        let links = self.links(id);
        prefer
            .and_then(|p| links.iter().find(|l| l.to == p))
            .and_then(|l| l.lane_to(lane).map(|b| (l.to, b)))
            .or_else(|| {
                links
                    .iter()
                    .find_map(|l| l.lane_to(lane).map(|b| (l.to, b)))
            })
    }

    /// The `(road, lane)` pairs whose ends lead onto the start of lane `lane` of road `id`.
    pub fn lane_prev(&self, id: RoadId, lane: u32) -> &[(RoadId, u32)] {
        self.slot(id)
            .and_then(|s| s.incoming.get(lane as usize))
            .map_or(&[], Vec::as_slice)
    }

    /// Time to drive the whole of road `id` at its speed limit, s.
    pub fn free_flow_s(&self, id: RoadId) -> f64 {
        self.get(id).map_or(f64::INFINITY, |g| {
            g.length_m() / (g.speed_limit_kmh() / 3.6)
        })
    }

    /// The quickest sequence of roads from `from` to `to` at free flow (each road driven whole
    /// at its speed limit), both included; ties go to the lower road id. `None` if `to` cannot
    /// be reached.
    pub fn shortest_path(&self, from: RoadId, to: RoadId) -> Option<Vec<RoadId>> {
        self.get(from)?;
        self.get(to)?;
        let n = self.slots.len();
        let mut best = vec![f64::INFINITY; n];
        let mut prev: Vec<Option<RoadId>> = vec![None; n];
        // Costs are non-negative, so their bit patterns order like the numbers.
        let mut heap = BinaryHeap::new();
        best[from.0 as usize] = 0.0;
        heap.push(Reverse((0.0f64.to_bits(), from)));
        while let Some(Reverse((bits, road))) = heap.pop() {
            let cost = f64::from_bits(bits);
            if cost > best[road.0 as usize] {
                continue;
            }
            if road == to {
                break;
            }
            for link in self.links(road) {
                let c = cost + self.free_flow_s(link.to);
                let k = link.to.0 as usize;
                if link.to == from {
                    continue;
                }
                if c < best[k] || (c == best[k] && prev[k].is_some_and(|p| road < p)) {
                    best[k] = c;
                    prev[k] = Some(road);
                    heap.push(Reverse((c.to_bits(), link.to)));
                }
            }
        }
        if !best[to.0 as usize].is_finite() {
            return None;
        }
        let mut path = vec![to];
        let mut at = to;
        while at != from {
            at = prev[at.0 as usize]?;
            path.push(at);
            if path.len() > n {
                return None;
            }
        }
        path.reverse();
        Some(path)
    }

    /// For each lane of `route[0]`: how far from that road's start a vehicle in the lane can
    /// drive along `route` without changing lanes, m (`INFINITY` when the lane leads on to the
    /// route's last road, a loop, or beyond [`LANE_REACH_HORIZON_M`]). One entry per lane.
    pub fn lane_reach(&self, route: &[RoadId]) -> Vec<f64> {
        let Some(first) = route.first().and_then(|&r| self.get(r)) else {
            return Vec::new();
        };
        // The roads within the horizon: the lanes of the last one reach without limit.
        let mut k = 0;
        let mut along = 0.0;
        while k < route.len() {
            let Some(g) = self.get(route[k]) else { break };
            k += 1;
            along += g.length_m();
            if g.is_closed() || along >= LANE_REACH_HORIZON_M {
                break;
            }
        }
        let last = self.get(route[k.max(1) - 1]).map_or(0, |g| g.lanes());
        let mut reach = vec![f64::INFINITY; last as usize];
        for i in (0..k.saturating_sub(1)).rev() {
            let Some(g) = self.get(route[i]) else {
                break;
            };
            let len = g.length_m();
            let mut here = vec![len; g.lanes() as usize];
            if let Some(link) = self.link(route[i], route[i + 1]) {
                for &(a, b) in &link.lanes {
                    if let (Some(h), Some(r)) = (here.get_mut(a as usize), reach.get(b as usize)) {
                        *h = h.max(len + r);
                    }
                }
            }
            reach = here;
        }
        reach.resize(first.lanes() as usize, f64::INFINITY);
        reach
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
    ///
    /// The same answer as projecting onto every road, but a road whose box is farther than the
    /// best distance found so far is not projected onto (in a city most are kilometres away).
    pub fn project(&self, pos: DVec3) -> Option<(RoadId, RoadProjection)> {
        let bounds: Vec<(f64, RoadId, &RoadGeometry)> = self
            .iter()
            .map(|(id, g)| (g.distance_bound(pos), id, g.as_ref()))
            .collect();
        // Start from the road with the nearest box, so the rest are mostly ruled out.
        let &(_, first, g) = bounds
            .iter()
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))?;
        let mut best = (first, g.project(pos));
        for &(bound, id, g) in &bounds {
            // Strictly farther: a tie could still win on its lower id.
            if id == first || bound > best.1.distance_m {
                continue;
            }
            let p = g.project(pos);
            // Ties go to the lower id, so the answer never depends on anything but the data.
            if p.distance_m
                .total_cmp(&best.1.distance_m)
                .then(id.cmp(&best.0))
                == std::cmp::Ordering::Less
            {
                best = (id, p);
            }
        }
        Some(best)
    }
}

/// The level's junctions; the network's junction paths are rebuilt when they change.
#[derive(Resource, Debug, Clone, Default, PartialEq)]
pub struct Junctions(pub Vec<JunctionSpec>);

/// Why the road network is out of date: the last edit made it invalid.
#[derive(Resource, Debug, Clone, Default, PartialEq)]
pub struct RoadNetworkError(pub Option<NetworkError>);

/// Keeps [`RoadShape`]s and the [`RoadNetwork`] in step with the [`Road`] components.
pub struct RoadPlugin;

impl SimPlugin for RoadPlugin {
    fn build(&self, sim: &mut Sim) {
        sim.world_mut().init_resource::<RoadNetwork>();
        sim.world_mut().init_resource::<RoadNetworkError>();
        sim.world_mut().init_resource::<Junctions>();
        sim.add_systems(StepSet::Prepare, rebuild_roads);
    }
}

/// The roads of `slots` that cross without meeting: roads meet at a junction (its paths, the
/// roads into and out of it) and where one links onto another.
fn crossings_of(
    slots: &[Option<Slot>],
    junctions: &[Junction],
    path_roads: &[Vec<RoadId>],
) -> Vec<(RoadId, RoadId)> {
    let mut places: Vec<Vec<u32>> = vec![Vec::new(); slots.len()];
    let mut add = |road: u32, place: u32| {
        if let Some(p) = places.get_mut(road as usize) {
            p.push(place);
        }
    };
    for (j, junction) in junctions.iter().enumerate() {
        for path in &junction.paths {
            add(path.from.0, j as u32);
            add(path.to.0, j as u32);
        }
        for road in path_roads.get(j).into_iter().flatten() {
            add(road.0, j as u32);
        }
    }
    let mut place = junctions.len() as u32;
    for (i, slot) in slots.iter().enumerate() {
        for link in slot.iter().flat_map(|s| &s.links) {
            add(i as u32, place);
            add(link.to.0, place);
            place += 1;
        }
    }
    let roads: Vec<crate::crossing::CrossingRoad> = slots
        .iter()
        .enumerate()
        .filter_map(|(i, slot)| {
            Some(crate::crossing::CrossingRoad {
                id: RoadId(i as u32),
                geometry: slot.as_ref()?.geometry.as_ref(),
                places: std::mem::take(&mut places[i]),
            })
        })
        .collect();
    crate::crossing::crossings(&roads)
}

/// Rebuilds the shapes of edited roads and then the network. An invalid edit leaves the last
/// good network in place and reports why in [`RoadNetworkError`].
pub fn rebuild_roads(
    mut commands: Commands,
    roads: Query<(Entity, &RoadId, Ref<Road>, Option<&RoadShape>)>,
    mut removed: RemovedComponents<Road>,
    junctions: Res<Junctions>,
    mut network: ResMut<RoadNetwork>,
    mut error: ResMut<RoadNetworkError>,
) {
    let removed_any = removed.read().count() > 0;
    if !removed_any
        && !junctions.is_changed()
        && !roads.iter().any(|(_, _, road, _)| road.is_changed())
    {
        return;
    }
    let mut sorted: Vec<_> = roads.iter().collect();
    sorted.sort_by_key(|(_, id, _, _)| **id);
    // Before the roads have shapes, a network built already from exactly these roads and
    // junctions (a level's loader builds it before the first step, for its initial vehicles)
    // is kept: building it again would give the same network, and on a city's thousands of
    // roads take as long as loading did. Each road takes its shape from it, so a later edit
    // builds only the roads edited.
    let unshaped = sorted.iter().all(|(_, _, _, shape)| shape.is_none());
    let level_roads = sorted.iter().map(|(_, id, road, _)| (**id, &road.0));
    if unshaped && !removed_any && network.is_built_from(level_roads, &junctions.0) {
        for (entity, id, _, _) in &sorted {
            if let Some(slot) = network.slot(**id) {
                commands.entity(*entity).insert(RoadShape {
                    geometry: slot.geometry.clone(),
                    meshes: slot.meshes.clone(),
                });
            }
        }
        error.0 = None;
        return;
    }
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
    match RoadNetwork::from_shapes(shapes, &junctions.0) {
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

    /// Road `a` (0-100 m along x), road `b` (120-200 m), one lane each, and a junction `j`
    /// joining them.
    fn two_roads_and_a_junction() -> ([RoadSpec; 2], crate::JunctionSpec) {
        let a = RoadSpec::through("a", 1, 50.0, &[DVec3::ZERO, DVec3::new(100.0, 0.0, 0.0)]);
        let b = RoadSpec::through(
            "b",
            1,
            50.0,
            &[DVec3::new(120.0, 0.0, 0.0), DVec3::new(200.0, 0.0, 0.0)],
        );
        let junction = crate::JunctionSpec {
            name: "j".into(),
            control: crate::Control::RightBeforeLeft,
            connections: vec![crate::ConnectionSpec {
                from: "a".into(),
                from_lane: 0,
                to: "b".into(),
                to_lane: 0,
            }],
            signal: None,
        };
        ([a, b], junction)
    }

    #[test]
    fn a_network_built_from_the_same_roads_is_kept_and_an_edit_rebuilds_it() {
        let (specs, junction) = two_roads_and_a_junction();
        // As a level's loader does: the network first, then the roads and junctions.
        let built = RoadNetwork::build_with(&specs, std::slice::from_ref(&junction))
            .expect("the network builds");
        assert!(built.is_built_from(
            specs.iter().enumerate().map(|(i, s)| (RoadId(i as u32), s)),
            std::slice::from_ref(&junction),
        ));
        let mut sim = sim_with(&specs);
        sim.world_mut().insert_resource(built.clone());
        sim.world_mut().resource_mut::<Junctions>().0 = vec![junction.clone()];
        sim.step();
        let revision = |sim: &Sim| sim.world().resource::<RoadNetwork>().revision();
        assert_eq!(revision(&sim), built.revision(), "the same roads: kept");
        let mut shapes = sim.world_mut().query::<(&RoadId, &RoadShape)>();
        let shaped: Vec<_> = shapes.iter(sim.world()).collect();
        assert_eq!(shaped.len(), 2);
        for (id, shape) in shaped {
            let kept = built.get(*id).expect("the road");
            assert!(
                Arc::ptr_eq(&shape.geometry, kept),
                "road {id:?} takes the kept shape"
            );
        }

        // A network of other roads is not kept: another junction.
        let mut other = junction.clone();
        other.connections[0].to_lane = 1;
        assert!(!built.is_built_from(
            specs.iter().enumerate().map(|(i, s)| (RoadId(i as u32), s)),
            std::slice::from_ref(&other),
        ));
        // Nor one road fewer, or one more.
        let js = std::slice::from_ref(&junction);
        let one = specs.iter().take(1).enumerate();
        assert!(!built.is_built_from(one.map(|(i, s)| (RoadId(i as u32), s)), js));
        let three = specs.iter().chain(&specs[..1]).enumerate();
        assert!(!built.is_built_from(three.map(|(i, s)| (RoadId(i as u32), s)), js));
        let swapped = [(RoadId(0), &specs[1]), (RoadId(1), &specs[0])];
        assert!(!built.is_built_from(swapped, js));

        // An edit after that rebuilds the network.
        let mut q = sim.world_mut().query::<&mut Road>();
        for mut road in q.iter_mut(sim.world_mut()) {
            if road.0.name == "b" {
                road.0.points[1].pos.x = 300.0;
            }
        }
        sim.step();
        assert_ne!(revision(&sim), built.revision());
        let net = sim.world().resource::<RoadNetwork>();
        let b = net.id("b").expect("road b");
        assert!((net.get(b).expect("b").length_m() - 180.0).abs() < 1e-6);
    }

    #[test]
    fn junctions_are_rebuilt_when_they_change() {
        let (specs, junction) = two_roads_and_a_junction();
        let mut sim = sim_with(&specs);
        sim.step();
        assert_eq!(sim.world().resource::<RoadNetwork>().len(), 2);
        sim.world_mut().resource_mut::<Junctions>().0 = vec![junction];
        sim.step();
        let net = sim.world().resource::<RoadNetwork>();
        assert_eq!(net.len(), 3);
        let path = net.id("j#0").expect("the junction's path");
        assert_eq!(net.junction_path(path), Some((0, 0)));
        assert!((net.get(path).expect("path").length_m() - 20.0).abs() < 1e-6);
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

    /// A three-lane approach splitting into a one-lane right branch and a two-lane left one,
    /// both joining a far road, and a slow shortcut: `a → r → far` and `a → l → far`.
    fn split() -> Vec<RoadSpec> {
        let w = crate::DEFAULT_LANE_WIDTH_M;
        let mut a = RoadSpec::through("a", 3, 100.0, &[DVec3::ZERO, DVec3::new(400.0, 0.0, 0.0)]);
        a.links = vec![
            crate::LinkSpec {
                to: "r".into(),
                lanes: vec![(0, 0)],
            },
            crate::LinkSpec {
                to: "l".into(),
                lanes: vec![(1, 0), (2, 1)],
            },
        ];
        // The right branch starts on lane 0's centre, the left one between lanes 1 and 2.
        let mut r = RoadSpec::through(
            "r",
            1,
            60.0,
            &[
                DVec3::new(400.0, -w, 0.0),
                DVec3::new(600.0, -w - 60.0, 0.0),
            ],
        );
        r.next = Some("far".into());
        let mut l = RoadSpec::through(
            "l",
            2,
            100.0,
            &[
                DVec3::new(400.0, 0.5 * w, 0.0),
                DVec3::new(600.0, 0.5 * w + 60.0, 0.0),
            ],
        );
        l.links = vec![crate::LinkSpec::to("far")];
        let far = RoadSpec::through(
            "far",
            2,
            100.0,
            &[
                DVec3::new(600.0, 0.5 * w + 60.0, 0.0),
                DVec3::new(900.0, 0.5 * w + 60.0, 0.0),
            ],
        );
        vec![a, r, l, far]
    }

    #[test]
    fn a_split_leads_each_lane_onto_its_branch() {
        let mut specs = split();
        // `r` does not end where `far` starts: drop its link for this test.
        specs[1].next = None;
        let net = RoadNetwork::build(&specs).expect("valid split");
        let (a, r, l) = (RoadId(0), RoadId(1), RoadId(2));
        assert_eq!(net.links(a).len(), 2);
        assert_eq!(net.lane_next(a, 0, None), Some((r, 0)));
        assert_eq!(net.lane_next(a, 2, None), Some((l, 1)));
        // A preferred branch the lane does not lead to is not taken.
        assert_eq!(net.lane_next(a, 0, Some(l)), Some((r, 0)));
        assert_eq!(net.lane_prev(l, 0), &[(a, 1)]);
        assert_eq!(net.lane_prev(r, 0), &[(a, 0)]);
        // Lanes reach as far as the route allows: only lane 0 carries on to `r`.
        let reach = net.lane_reach(&[a, r]);
        assert_eq!(reach[0], f64::INFINITY);
        assert!((reach[1] - 400.0).abs() < 1e-6 && (reach[2] - 400.0).abs() < 1e-6);
        let reach = net.lane_reach(&[a, l, RoadId(3)]);
        assert!((reach[0] - 400.0).abs() < 1e-6);
        assert_eq!(reach[1], f64::INFINITY);
        // Without a next road every lane reaches on.
        assert!(net.lane_reach(&[a]).iter().all(|r| r.is_infinite()));
    }

    #[test]
    fn the_shortest_path_is_the_quickest_at_free_flow() {
        let mut specs = split();
        specs[1].points[1].pos = DVec3::new(600.0, 0.5 * crate::DEFAULT_LANE_WIDTH_M + 60.0, 0.0);
        let net = RoadNetwork::build(&specs).expect("valid roads");
        let (a, r, l, far) = (RoadId(0), RoadId(1), RoadId(2), RoadId(3));
        // Both branches are about as long, and `l` is faster.
        assert_eq!(net.shortest_path(a, far), Some(vec![a, l, far]));
        specs[2].speed_limit_kmh = 30.0;
        let net = RoadNetwork::build(&specs).expect("valid roads");
        assert_eq!(net.shortest_path(a, far), Some(vec![a, r, far]));
        assert_eq!(net.shortest_path(far, a), None);
        assert_eq!(net.shortest_path(a, a), Some(vec![a]));
    }

    #[test]
    fn links_are_checked_lane_by_lane() {
        let mut specs = split();
        specs[1].next = None;
        specs[0].links[1].lanes = vec![(1, 0), (2, 2)];
        assert!(matches!(
            RoadNetwork::build(&specs),
            Err(NetworkError::LinkLane {
                to_lane: 2,
                lanes: 2,
                ..
            })
        ));
        specs[0].links[1].lanes = vec![(0, 1), (2, 1)];
        let e = RoadNetwork::build(&specs).expect_err("lane 0 is 4.5 m from lane 1 of l");
        assert!(
            matches!(
                e,
                NetworkError::LaneGap {
                    from_lane: 0,
                    to_lane: 1,
                    ..
                }
            ),
            "{e}"
        );
        specs[0].links[1].lanes = vec![(1, 0)];
        specs[0].links.push(crate::LinkSpec::to("l"));
        assert!(matches!(
            RoadNetwork::build(&specs),
            Err(NetworkError::DuplicateLink { .. })
        ));
    }

    #[test]
    fn the_nearest_road_is_the_one_projecting_onto_every_road_finds() {
        // Curving roads in a fan and a ring of points around and among them, some above.
        let specs: Vec<RoadSpec> = (0..12)
            .map(|k| {
                let a = f64::from(k) * 0.5;
                let (c, s) = (a.cos(), a.sin());
                RoadSpec::through(
                    &format!("r{k}"),
                    1 + k as u32 % 3,
                    50.0,
                    &[
                        DVec3::new(20.0 * c, 20.0 * s, 0.0),
                        DVec3::new(60.0 * c - 10.0 * s, 60.0 * s + 10.0 * c, f64::from(k)),
                        DVec3::new(120.0 * c, 120.0 * s, 0.0),
                    ],
                )
            })
            .collect();
        let network = RoadNetwork::build(&specs).expect("roads apart");
        for i in 0..400 {
            let t = f64::from(i);
            let pos = DVec3::new(
                (t * 0.37).sin() * (20.0 + t * 0.3),
                (t * 0.53).cos() * (20.0 + t * 0.3),
                (t * 0.11).sin() * 6.0,
            );
            let every = network
                .iter()
                .map(|(id, g)| (id, g.project(pos)))
                .min_by(|a, b| {
                    a.1.distance_m
                        .total_cmp(&b.1.distance_m)
                        .then(a.0.cmp(&b.0))
                })
                .expect("roads");
            let (id, p) = network.project(pos).expect("roads");
            assert_eq!((id, p), every, "at {pos}");
            for (_, g) in network.iter() {
                assert!(g.distance_bound(pos) <= g.project(pos).distance_m);
            }
        }
    }
}
