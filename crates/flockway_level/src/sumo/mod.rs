//! SUMO networks in: a `.net.xml` (as `netconvert` writes it, from OpenStreetMap, OpenDRIVE or
//! plain node and edge files) becomes a level that runs.
//!
//! - Every edge that is not internal becomes a road of the same name, its lanes (SUMO's lane 0 is
//!   the rightmost, as ours), width, speed limit and centre line taken from its lanes' shapes.
//! - Every junction with connections becomes a junction of the same name: its connections (in
//!   SUMO's link-index order at a traffic light, so each phase's state reads letter for letter),
//!   its right of way (`traffic_light` → `Signal` with the `tlLogic` program, `priority` and
//!   `priority_stop` → `Priority` with the incoming edges of the highest priority as major (the
//!   two that arrive most nearly head-on when more tie),
//!   `right_before_left` → `RightBeforeLeft`, `allway_stop` → `AllWayStop`; any other type,
//!   `unregulated` among them, as `priority`: cars that would touch must give way somehow).
//! - Where one edge simply goes on as another (a lane added or dropped: a motorway's
//!   acceleration and deceleration lanes), or two lanes meet, the roads are linked rather than
//!   joined through a junction.
//! - Where the network is open, traffic comes and goes: a spawner on every lane of each edge
//!   nothing leads onto, its vehicles routed to every edge that leads nowhere (the shortest way
//!   there), and a destroyer near the end of each of those.
//!
//! The import goes in three steps, each in a module of its own: [`net`] reads the file into the
//! network as SUMO describes it (every element with its place in the file, for errors),
//! [`network`] makes from it the network cars drive (car lanes only, simple nodes closed, main
//! roads, the fringe), and [`build`] makes the level. [`demand`] adds SUMO's demand to it.

mod build;
mod demand;
mod net;
mod network;

pub use demand::{DemandReport, import_sumo};

use crate::schema::Level;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Why a SUMO network could not be imported: where in the file, and what was expected.
#[derive(Debug, thiserror::Error)]
#[error("{}:{line}:{column}: {message}", path.display())]
pub struct ImportError {
    /// The network file.
    pub path: PathBuf,
    /// Line, from 1.
    pub line: u32,
    /// Column, from 1.
    pub column: u32,
    /// What is wrong, and what was expected.
    pub message: String,
}

/// A SUMO XML file (DTDs allowed), or an error at the place it stops being well-formed.
pub(crate) fn parse_xml<'t>(
    text: &'t str,
    path: &Path,
) -> Result<roxmltree::Document<'t>, ImportError> {
    let options = roxmltree::ParsingOptions {
        allow_dtd: true,
        ..Default::default()
    };
    roxmltree::Document::parse_with_options(text, options).map_err(|e| {
        let pos = e.pos();
        ImportError {
            path: path.to_owned(),
            line: pos.row,
            column: pos.col,
            message: format!("not a well-formed XML file: {e}"),
        }
    })
}

/// An import error at `node` of the file `path`.
pub(crate) fn error_at(path: &Path, node: roxmltree::Node, message: String) -> ImportError {
    let pos = node.document().text_pos_at(node.range().start);
    ImportError {
        path: path.to_owned(),
        line: pos.row,
        column: pos.col,
        message,
    }
}

/// Reads a SUMO network file into a level named `name`.
pub fn import_sumo_net(text: &str, path: &Path, name: &str) -> Result<Level, ImportError> {
    import_net(text, path, name, false).map(|i| i.level)
}

/// For each imported edge, the car lane each of SUMO's lane indices became (`None`: a lane cars
/// may not use, left out).
pub(crate) type LaneMaps = BTreeMap<String, Vec<Option<u32>>>;

/// A network imported: the level, and what its demand needs to know of the import.
pub(crate) struct Imported {
    pub level: Level,
    /// The lane numbering of each edge kept.
    pub lane_maps: LaneMaps,
    /// What the level does not do as SUMO would, each once.
    pub warnings: Vec<String>,
    /// Edges left out because they lie inside a junction (a route passes over them).
    pub inside_junctions: BTreeSet<String>,
}

/// [`import_sumo_net`], with what a demand read onto the level needs. With `demand` to come,
/// a network with no way in is no error: the demand's vehicles leave on their own routes.
pub(crate) fn import_net(
    text: &str,
    path: &Path,
    name: &str,
    demand: bool,
) -> Result<Imported, ImportError> {
    let mut net = net::read(text, path)?;
    let mut connections = network::car_connections(&net, path)?;
    network::close_simple_nodes(&mut net.edges, &mut connections);
    let inside_junctions = network::merge_close_junctions(&mut net, &mut connections);
    let (level, lane_maps) = build::level(&net, &connections, path, name, demand)?;
    Ok(Imported {
        level,
        lane_maps,
        warnings: net.warnings,
        inside_junctions: inside_junctions.into_iter().collect(),
    })
}

/// The file name of `path`, for a level's description.
fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}
