//! Flockway's window: the editor as a view over the headless editing model (`flockway_edit`),
//! play mode, the HUD and the winit loop, drawn by the renderer (`flockway_render`, re-exported
//! here). This is the only crate that depends on winit and egui; the simulation crates below it
//! build and test without a display.

mod app;
mod focus;
mod play;
mod ui;
mod window;

pub use app::{AppState, PICK_PX, Pending, RoadPick, Selection, SideTab, Tool, spawner_spot};
pub use flockway_edit::{
    ACCELERATION_LANE_M, Command, EditError, Editor, MarkerKind, UNDO_DEPTH, autosave_path,
    join_end, join_exit, join_side, playable, recover,
};
pub use flockway_render::{
    COM_HEIGHT_SHARE, Camera, CarVertex, ColourBy, DEPTH_FORMAT, EMPTY_VIEW_M, Gpu, Image,
    MSAA_SAMPLES, OFFSCREEN_FORMAT, ORBIT_FOV_RAD, OffscreenView, RenderError, Rendered, SKY,
    SceneRenderer, Snapshot, SnapshotError, StaticScene, Targets, VehicleFrame, VehicleInstance,
    Vertex, View, box_faces, car_mesh, palette, render_image, render_level,
};
pub use play::{FRAME_BUDGET, HudStats, PlaySession, PlaySpeed};
pub use ui::{PANEL_WIDTH, ui};
pub use window::{WindowError, run};
