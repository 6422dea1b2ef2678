//! Flockway roads: smooth splines through the points a user places, with lanes, bank, width and
//! guardrails, and the geometry queries every other system needs.
//!
//! A [`RoadSpec`] is what the user edits and the level stores. [`RoadGeometry`] evaluates it once
//! per edit: a centripetal Catmull-Rom centre line (open or a seamless closed loop) with an
//! arc-length table for O(log n) frames at an arc position, and a grid index for closest-point
//! queries. [`RoadMeshes`] holds the surface, markings and guardrails for physics and rendering.
//! In the ECS world, [`RoadPlugin`] keeps the [`RoadNetwork`] resource in step with [`Road`]
//! components.
//!
//! Conventions: x east, y north, z up (metres); lateral offsets are positive to the left of the
//! direction of travel; lane 0 is the rightmost lane.

mod crossing;
pub use crossing::segments_apart_m;
mod error;
mod geometry;
mod grid;
mod junction;
mod mesh;
mod network;
mod spec;
mod spline;
mod validate;

pub use error::RoadError;
pub use geometry::{
    CURVATURE_BIN_M, RoadCursor, RoadFrame, RoadGeometry, RoadProjection, lane_offset,
};
pub use junction::{
    BODY_LENGTH_M, BODY_WIDTH_M, CONFLICT_CLEARANCE_M, Conflict, ConnectionSpec, Control, Junction,
    JunctionError, JunctionPath, JunctionSpec, Phase, SignalProgram, SignalState, Turn,
    check_program, check_state, path_name,
};
pub use mesh::{
    DASH_M, GAP_M, GUARDRAIL_HEIGHT_M, GUARDRAIL_OFFSET_M, GuardrailRun, MARKING_WIDTH_M, Mesh,
    RoadMeshes, STATION_STEP_M, Side,
};
pub use network::{
    JunctionAhead, Junctions, LANE_REACH_HORIZON_M, Link, MAX_CONNECTION_GAP_M, NetworkError, Road,
    RoadId, RoadNetwork, RoadNetworkError, RoadPlugin, RoadShape, rebuild_roads,
};
pub use spec::{ControlPoint, DEFAULT_LANE_WIDTH_M, LinkSpec, RoadSpec};
pub use validate::{
    BANK_DEG, COORD_M, LANE_WIDTH_M, LANES, MAX_BANK_DEG, MAX_COORD_M, MAX_LANES,
    MAX_POINT_SPACING_M, MAX_POINTS, MAX_WIDTH_M, MIN_POINT_SPACING_M, SPEED_LIMIT_KMH, WIDTH_M,
};

/// The road types most users need.
pub mod prelude {
    pub use crate::{
        ControlPoint, Road, RoadFrame, RoadGeometry, RoadId, RoadNetwork, RoadPlugin,
        RoadProjection, RoadSpec,
    };
}

#[cfg(test)]
mod tests;
