//! Flockway's renderer: the scene of a level (road meshes, markers, vehicles as instances), the
//! cameras, and drawing it with wgpu — into the window's surface or an off-screen image
//! (`flockway render`, Python's `Sim.render`). It depends on wgpu but not on winit or egui, so
//! the Python module renders without the window's crates.

mod camera;
mod render;
mod scene;
mod snapshot;

pub use camera::{Camera, ORBIT_FOV_RAD};
pub use render::{
    DEPTH_FORMAT, Gpu, Image, MSAA_SAMPLES, OFFSCREEN_FORMAT, RenderError, SKY, SceneRenderer,
    Targets, render_image,
};
pub use scene::{
    COM_HEIGHT_SHARE, CarVertex, ColourBy, EMPTY_VIEW_M, StaticScene, VehicleFrame,
    VehicleInstance, Vertex, box_faces, car_mesh, palette,
};
pub use snapshot::{OffscreenView, Rendered, Snapshot, SnapshotError, View, render_level};
