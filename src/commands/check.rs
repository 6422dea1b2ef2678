//! `flockway check`: levels loaded and validated (with their vehicle and driver files), not run.

use flockway::level::load_level;
use flockway::run::{RunError, level_name};
use std::path::PathBuf;
use std::process::ExitCode;

pub fn check(levels: &[PathBuf]) -> ExitCode {
    let mut bad = 0;
    for path in levels {
        let loaded = load_level(path).map_err(RunError::from).and_then(|level| {
            let name = level_name(&level, path);
            let assets = flockway::run::find_assets_dir(Some(path));
            flockway::run::load_vehicle_types(&level, &name, &assets)?;
            flockway::run::load_driver_profiles(&level, &name, &assets)?;
            Ok((level, name))
        });
        match loaded {
            Ok((level, name)) => {
                super::print_warnings(&level, path);
                outln!(
                    "ok    {} ({}, {} road(s), {} vehicle type(s))",
                    path.display(),
                    name,
                    level.roads.len(),
                    level.vehicle_types.len()
                )
            }
            Err(e) => {
                bad += 1;
                eprintln!("error: {e}");
            }
        }
    }
    if bad == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(2)
    }
}
