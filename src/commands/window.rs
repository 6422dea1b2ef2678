//! `flockway edit`, `flockway play` and `flockway render`: the window crate's editor, play mode
//! and off-screen renderer (absent from a build without the `window` feature).

use super::fail;
use crate::cli::CameraArg;
use std::path::Path;
use std::process::ExitCode;

/// Opens the editor on a level (a new one without a path), playing it if `play`.
#[cfg(feature = "window")]
pub fn window(level: Option<&Path>, play: bool) -> ExitCode {
    use flockway::app::{AppState, Editor};
    let editor = match level {
        Some(path) => match Editor::open(path) {
            Ok(e) => e,
            Err(e) => return fail(e),
        },
        None => Editor::new(),
    };
    let assets = flockway::run::find_assets_dir(level);
    let mut app = AppState::new(editor, assets.clone());
    // The number keys load the shipped levels beside the assets.
    if let Some(dir) = assets.parent().map(|p| p.join("levels"))
        && let Ok(files) = flockway::run::batch::ron_files_in(&dir)
    {
        app.shipped = files;
    }
    app.recovered = flockway::app::recover(level);
    if play {
        app.play();
    }
    match flockway::app::run(app) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => fail(e),
    }
}

/// Without the window there is no editor.
#[cfg(not(feature = "window"))]
pub fn window(_: Option<&Path>, _: bool) -> ExitCode {
    fail("this build has no window (built without the `window` feature); use `flockway run`")
}

/// Renders a level at a moment to a PNG.
#[cfg(feature = "window")]
pub fn render(
    path: &Path,
    out: &Path,
    at: f64,
    size: (u32, u32),
    camera: CameraArg,
    seed: Option<u64>,
    region: Option<[f64; 4]>,
) -> ExitCode {
    use flockway::app::{Snapshot, render_level};
    let level = match flockway::level::load_level(path) {
        Ok(l) => l,
        Err(e) => return fail(e),
    };
    let name = flockway::run::level_name(&level, path);
    let snapshot = Snapshot {
        at_s: at,
        size,
        view: camera.into(),
        seed,
        region,
        assets: flockway::run::find_assets_dir(Some(path)),
    };
    match render_level(level, &name, &snapshot, out) {
        Ok(r) => {
            outln!(
                "wrote {} ({}×{}, {} vehicles at {:.2} s, {})",
                out.display(),
                size.0,
                size.1,
                r.vehicles,
                r.sim_s,
                r.adapter
            );
            ExitCode::SUCCESS
        }
        Err(e) => fail(e),
    }
}

/// Without the window there is no renderer.
#[cfg(not(feature = "window"))]
pub fn render(
    _: &Path,
    _: &Path,
    _: f64,
    _: (u32, u32),
    _: CameraArg,
    _: Option<u64>,
    _: Option<[f64; 4]>,
) -> ExitCode {
    fail("this build has no renderer (built without the `window` feature); use `flockway run`")
}
