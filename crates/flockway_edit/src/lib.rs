//! Editing Flockway levels without a window: the level document with undo and redo
//! ([`Editor`]), the edits it takes ([`Command`], plain serde data), placement of markers and
//! prefabs, joins of roads, the network as drawn, checked application (an edit that would make
//! the level invalid is refused with an [`EditError`] that says what and where), and scripts of
//! edits ([`apply_script`], behind `flockway edit --apply`).
//!
//! The window's editor, the command line and Python all edit through this crate; it depends on
//! the level and road crates only (no winit, wgpu or egui).

mod apply;
mod command;
mod drawn;
mod editor;
mod error;
mod joins;
mod place;
mod script;

pub use command::{Command, MarkerKind, Target};
pub use drawn::{level_network, network_as_drawn, playable};
pub use editor::{Editor, UNDO_DEPTH, autosave_path, recover};
pub use error::EditError;
pub use joins::{
    ACCELERATION_LANE_M, JoinError, MIN_ACCELERATION_LANE_M, join_end, join_exit, join_side,
};
pub use place::{
    Placement, PrefabKind, TRIGGER_LENGTH_M, TRIGGER_RAISE_KMH, place_marker, place_prefab,
};
pub use script::{ScriptError, apply_script, parse_script};
