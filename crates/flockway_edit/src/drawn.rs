//! The level as drawn, as the editor shows it and as Play runs it: roads still being drawn and
//! links or junctions that cannot be built are left out, so everything else still shows, picks
//! and runs.

use flockway_level::Level;
use flockway_road::{JunctionSpec, NetworkError, RoadGeometry, RoadNetwork, RoadSpec};

/// The level as it can run: without roads of fewer than two points (still being drawn) and the
/// connections onto them. Returns it and how many roads were left out.
pub fn playable(level: &Level) -> (Level, usize) {
    let drafts: Vec<String> = level
        .roads
        .iter()
        .filter(|r| r.points.len() < 2)
        .map(|r| r.name.clone())
        .collect();
    let mut out = level.clone();
    out.roads.retain(|r| r.points.len() >= 2);
    for r in &mut out.roads {
        if r.next.as_ref().is_some_and(|n| drafts.contains(n)) {
            r.next = None;
        }
    }
    (out, drafts.len())
}

/// The network of a level's roads as drawn: every road that forms a road on its own (a road of
/// one point does not yet), connections kept where both ends exist.
pub fn level_network(level: &Level) -> RoadNetwork {
    let ok: Vec<RoadSpec> = level
        .roads
        .iter()
        .filter(|r| RoadGeometry::new(r).is_ok())
        .cloned()
        .collect();
    network_as_drawn(ok, level.junctions.clone())
}

/// The network of roads as drawn: a link that cannot be built (its road's end dragged away from
/// where it leads, a road still being drawn) is left out, with the other links of its road, and
/// a junction that cannot be built (a road of it moved or deleted) is left out, so everything
/// else still shows and picks.
pub fn network_as_drawn(mut roads: Vec<RoadSpec>, mut junctions: Vec<JunctionSpec>) -> RoadNetwork {
    for _ in 0..=roads.len() + junctions.len() {
        let failing = match RoadNetwork::build_with(&roads, &junctions) {
            Ok(network) => return network,
            Err(NetworkError::Junction(e)) => {
                junctions.retain(|j| j.name != e.junction());
                continue;
            }
            Err(NetworkError::DuplicateJunction(name)) => {
                if let Some(k) = junctions.iter().rposition(|j| j.name == name) {
                    junctions.remove(k);
                }
                continue;
            }
            Err(
                NetworkError::UnknownNext { road, .. }
                | NetworkError::LinkLane { road, .. }
                | NetworkError::DuplicateLink { road, .. }
                | NetworkError::LaneGap { road, .. }
                | NetworkError::Gap { road, .. },
            ) => Some(road),
            Err(_) => None,
        };
        match failing.and_then(|name| roads.iter_mut().find(|r| r.name == name)) {
            Some(r) if r.next.is_some() || !r.links.is_empty() => {
                r.next = None;
                r.links.clear();
            }
            _ => break,
        }
    }
    roads.iter_mut().for_each(|r| {
        r.next = None;
        r.links.clear();
    });
    RoadNetwork::build(&roads).unwrap_or_default()
}
