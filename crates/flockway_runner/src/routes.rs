//! Routes set from outside between steps: a vehicle's roads ahead, or a destination it takes
//! the quickest way to, checked against the network before anything changes.

use crate::session::{Session, SessionError};
use crate::world::route_through;
use flockway_drivers::Route;
use flockway_road::{RoadId, RoadNetwork};
use std::sync::Arc;

/// Where a vehicle is to go: along roads, or the quickest way to one.
#[derive(Debug, Clone, PartialEq)]
pub enum Heading<'a> {
    /// These roads in order (the road it is on may come first; junction paths are found).
    Roads(&'a [String]),
    /// The quickest path at free flow to this road.
    Destination(&'a str),
}

/// The road named `name`, or an error naming it.
fn road_id(network: &RoadNetwork, name: &str) -> Result<RoadId, SessionError> {
    network
        .id(name)
        .ok_or_else(|| SessionError::Value(format!("there is no road `{name}`")))
}

/// The route from road `start` that `heading` asks for, checked: every road leads onto the
/// next (through a junction where two roads meet in one).
pub fn route_from(
    network: &RoadNetwork,
    start: RoadId,
    heading: &Heading,
) -> Result<Route, SessionError> {
    let name = |id: RoadId| network.get(id).map_or("?", |g| g.name()).to_owned();
    match heading {
        Heading::Roads(names) => {
            if names.is_empty() {
                return Err(SessionError::Value(
                    "an empty route: give the roads to take, in order".into(),
                ));
            }
            let ids: Vec<RoadId> = names
                .iter()
                .map(|n| road_id(network, n))
                .collect::<Result<_, _>>()?;
            let roads = route_through(network, start, &ids);
            for pair in roads.windows(2) {
                if network.link(pair[0], pair[1]).is_none() {
                    return Err(SessionError::Value(format!(
                        "road `{}` does not lead onto road `{}`",
                        name(pair[0]),
                        name(pair[1])
                    )));
                }
            }
            let label = names.last().map_or("", String::as_str);
            Ok(Route::along(Arc::from(label), roads))
        }
        Heading::Destination(dest) => {
            let to = road_id(network, dest)?;
            let roads = network.shortest_path(start, to).ok_or_else(|| {
                SessionError::Value(format!(
                    "road `{dest}` cannot be reached from road `{}`",
                    name(start)
                ))
            })?;
            Ok(Route::along(Arc::from(*dest), roads))
        }
    }
}

impl Session {
    /// Gives vehicle `id` a new route from the road it is on: along roads, or the quickest
    /// way to a destination. It takes the new route's lanes from here on.
    pub fn set_heading(&mut self, id: u32, heading: &Heading) -> Result<(), SessionError> {
        let entity = self.entity_of(id)?;
        let world = self.runner_mut().sim_mut().world_mut();
        let road = world
            .get::<flockway_vehicle::RoadTrack>(entity)
            .map(|t| t.road)
            .ok_or(SessionError::NoVehicle(id))?;
        let route = route_from(world.resource::<RoadNetwork>(), road, heading)
            .map_err(|e| SessionError::Value(format!("vehicle {id}: {e}")))?;
        world.entity_mut(entity).insert(route);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use flockway_level::load_level;

    fn crossroads() -> RoadNetwork {
        let level = load_level(std::path::Path::new("../../levels/crossroads_signal.ron"))
            .expect("shipped level");
        RoadNetwork::build_with(&level.roads, &level.junctions).expect("network")
    }

    #[test]
    fn a_route_goes_through_the_junction_path_and_a_destination_the_quickest_way() {
        let net = crossroads();
        let west = net.id("west in").expect("road");
        let names = ["west in".to_owned(), "north out".to_owned()];
        let r = route_from(&net, west, &Heading::Roads(&names)).expect("a route");
        let ahead: Vec<&str> = r
            .ahead()
            .iter()
            .map(|&id| net.get(id).expect("road").name())
            .collect();
        assert_eq!(ahead.len(), 3);
        assert_eq!((ahead[0], ahead[2]), ("west in", "north out"));
        assert!(ahead[1].starts_with("crossroads#"));
        assert_eq!(&*r.name, "north out");
        let d = route_from(&net, west, &Heading::Destination("south out")).expect("reachable");
        assert_eq!(d.destination(), net.id("south out"));
        // Errors name what is wrong.
        let bad = ["east out".to_owned()];
        let err = route_from(
            &net,
            net.id("east in").expect("road"),
            &Heading::Roads(&bad),
        )
        .expect_err("a U-turn the junction lacks")
        .to_string();
        assert!(err.contains("does not lead onto road `east out`"), "{err}");
        let err = route_from(&net, west, &Heading::Destination("east in"))
            .expect_err("an approach from the other side")
            .to_string();
        assert!(err.contains("cannot be reached"), "{err}");
        let err = route_from(&net, west, &Heading::Roads(&["nowhere".to_owned()]))
            .expect_err("unknown")
            .to_string();
        assert!(err.contains("no road `nowhere`"), "{err}");
        assert!(route_from(&net, west, &Heading::Roads(&[])).is_err());
    }
}
