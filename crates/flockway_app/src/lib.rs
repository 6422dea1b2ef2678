//! Flockway's window: the wgpu renderer (on screen and off screen), the road editor's view over
//! the headless editing model (`flockway_edit`), play mode and the HUD. This is the only crate that depends on winit, wgpu and egui; the simulation
//! crates below it build and test without a display.

mod app;
mod camera;
mod focus;
mod play;
mod render;
mod scene;
mod snapshot;
mod ui;
mod window;

pub use app::{AppState, PICK_PX, Pending, RoadPick, Selection, SideTab, Tool, spawner_spot};
pub use camera::{Camera, ORBIT_FOV_RAD};
pub use flockway_edit::{
    ACCELERATION_LANE_M, Command, EditError, Editor, MarkerKind, UNDO_DEPTH, autosave_path,
    join_end, join_exit, join_side, playable, recover,
};
pub use play::{FRAME_BUDGET, HudStats, PlaySession, PlaySpeed};
pub use render::{
    DEPTH_FORMAT, Gpu, Image, MSAA_SAMPLES, OFFSCREEN_FORMAT, RenderError, SKY, SceneRenderer,
    Targets, render_image,
};
pub use scene::{
    COM_HEIGHT_SHARE, CarVertex, ColourBy, EMPTY_VIEW_M, StaticScene, VehicleFrame,
    VehicleInstance, Vertex, box_faces, car_mesh, palette,
};
pub use snapshot::{OffscreenView, Rendered, Snapshot, SnapshotError, View, render_level};
pub use ui::{PANEL_WIDTH, ui};
pub use window::{WindowError, run};
