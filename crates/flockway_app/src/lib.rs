//! Flockway's window: the wgpu renderer (on screen and off screen), the road editor's model, play
//! mode and the HUD. This is the only crate that depends on winit, wgpu and egui; the simulation
//! crates below it build and test without a display.

mod camera;
mod editor;
mod render;
mod scene;

pub use camera::{Camera, ORBIT_FOV_RAD};
pub use editor::{Command, EditError, Editor, MarkerKind, UNDO_DEPTH, autosave_path, recover};
pub use render::{
    DEPTH_FORMAT, Gpu, Image, MSAA_SAMPLES, OFFSCREEN_FORMAT, RenderError, SKY, SceneRenderer,
    Targets, render_image,
};
pub use scene::{
    COM_HEIGHT_SHARE, CarVertex, StaticScene, VehicleFrame, VehicleInstance, Vertex, box_faces,
    car_mesh, palette,
};
