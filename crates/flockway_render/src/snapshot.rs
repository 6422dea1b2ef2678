//! `flockway render`: a level simulated headless to a moment, its scene drawn off screen with
//! the window's renderer, and saved as a PNG.

use crate::camera::Camera;
use crate::render::{Gpu, Image, OFFSCREEN_FORMAT, RenderError, SceneRenderer, render_image};
use crate::scene::{StaticScene, VehicleFrame};
use flockway_level::Level;
use flockway_road::RoadNetwork;
use flockway_runner::{MAX_RUN_SECONDS, RunError, RunOptions, Runner};
use glam::Vec3;
use std::path::{Path, PathBuf};

/// The view of a rendered picture.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum View {
    /// Straight down, the whole level in view.
    #[default]
    Top,
    /// Perspective from the south-west, the whole level in view.
    Orbit,
}

/// What to render: when, how large, from where, with which seed.
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    /// Simulated seconds before the picture (0: as the level starts, after its first step).
    pub at_s: f64,
    /// Image size, pixels.
    pub size: (u32, u32),
    /// The camera.
    pub view: View,
    /// Seed instead of the level's.
    pub seed: Option<u64>,
    /// Only this part of the level in view: the ground box `[x0, y0, x1, y1]`, m (`None`: all of
    /// it).
    pub region: Option<[f64; 4]>,
    /// The `assets/` directory of the level's vehicle and driver files.
    pub assets: PathBuf,
}

/// Why a picture could not be made.
#[derive(Debug, thiserror::Error)]
pub enum SnapshotError {
    /// `at_s` is not a time a run can reach.
    #[error("--at {0}: expected simulated seconds from 0 to a week")]
    Time(f64),
    /// The level could not be run.
    #[error(transparent)]
    Run(#[from] RunError),
    /// The picture could not be drawn or saved.
    #[error(transparent)]
    Render(#[from] RenderError),
}

/// What was rendered, for the command's message.
#[derive(Debug, Clone, PartialEq)]
pub struct Rendered {
    /// Vehicles in the picture.
    pub vehicles: usize,
    /// The simulated time shown, s.
    pub sim_s: f64,
    /// The graphics adapter that drew it.
    pub adapter: String,
}

/// Runs `level` (named `name`) to `snapshot.at_s` and writes its scene to `out` as a PNG.
pub fn render_level(
    level: Level,
    name: &str,
    snapshot: &Snapshot,
    out: &Path,
) -> Result<Rendered, SnapshotError> {
    let at = snapshot.at_s;
    if !(at.is_finite() && (0.0..=MAX_RUN_SECONDS).contains(&at)) {
        return Err(SnapshotError::Time(at));
    }
    let options = RunOptions {
        // At least one step, so the level's initial vehicles are on the road.
        seconds: Some(at.max(1.0 / 120.0)),
        seed: snapshot.seed,
        assets: Some(snapshot.assets.clone()),
        ..RunOptions::default()
    };
    let mut runner = Runner::new(level, name, &options)?;
    while runner.ticks_done() < runner.total_ticks() {
        runner.step(120)?;
    }
    let mut view = OffscreenView::new(
        runner.sim().world().resource::<RoadNetwork>(),
        runner.level(),
    )?;
    let vehicles = view.capture(runner.sim_mut().world_mut());
    view.render(snapshot.size, snapshot.view, snapshot.region)?
        .save_png(out)?;
    Ok(Rendered {
        vehicles,
        sim_s: runner.ticks_done() as f64 / 120.0,
        adapter: view.gpu.describe(),
    })
}

/// An off-screen camera on a level: the window's renderer without a window, drawing the roads
/// once and the vehicles as often as they are captured — `flockway render`'s picture, and the
/// Python environments' `rgb_array` frames.
pub struct OffscreenView {
    gpu: Gpu,
    renderer: SceneRenderer,
    min: Vec3,
    max: Vec3,
}

impl OffscreenView {
    /// A view of the level whose roads are `network`: a headless device (Vulkan, lavapipe
    /// without a GPU, or GL) and the static scene uploaded.
    pub fn new(network: &RoadNetwork, level: &Level) -> Result<OffscreenView, RenderError> {
        let gpu = Gpu::headless()?;
        let scene = StaticScene::build(network, level);
        let mut renderer = SceneRenderer::new(&gpu.device, OFFSCREEN_FORMAT);
        renderer.set_static(&gpu.device, &scene);
        Ok(OffscreenView {
            gpu,
            renderer,
            min: scene.min,
            max: scene.max,
        })
    }

    /// Takes the vehicles' (and signals') poses from `world` for the next pictures; returns how
    /// many vehicles there are.
    pub fn capture(&mut self, world: &mut bevy_ecs::world::World) -> usize {
        let mut vehicles = VehicleFrame::default();
        vehicles.capture(world);
        let drawn: Vec<_> = vehicles
            .instances
            .iter()
            .chain(&vehicles.signals)
            .copied()
            .collect();
        self.renderer
            .set_vehicles(&self.gpu.device, &self.gpu.queue, &drawn);
        vehicles.instances.len()
    }

    /// Draws the scene as last captured, `size` pixels, from `view`, of the ground box
    /// `region` (`[x0, y0, x1, y1]`, m; `None`: the whole level).
    pub fn render(
        &self,
        size: (u32, u32),
        view: View,
        region: Option<[f64; 4]>,
    ) -> Result<Image, RenderError> {
        let (w, h) = size;
        let (min, max) = match region {
            Some([x0, y0, x1, y1]) => (
                Vec3::new(x0 as f32, y0 as f32, self.min.z),
                Vec3::new(x1 as f32, y1 as f32, self.max.z),
            ),
            None => (self.min, self.max),
        };
        let camera = match view {
            View::Top => Camera::top_fit(min, max, w as f32 / h.max(1) as f32),
            View::Orbit => Camera::orbit_fit(min, max),
        };
        render_image(&self.gpu, &self.renderer, &camera, size)
    }

    /// The graphics adapter drawing it.
    pub fn adapter(&self) -> String {
        self.gpu.describe()
    }
}
