//! `flockway dyno`: a vehicle definition measured on the test tracks.

use super::fail;
use flockway::vehicle::{DynoReport, DynoSettings, VehicleParams, VehicleType, run_dyno};
use std::process::ExitCode;
use std::sync::Arc;

pub fn dyno(vehicle: Option<&std::path::Path>, json: bool) -> ExitCode {
    let params = match vehicle {
        Some(path) => match VehicleParams::load(path) {
            Ok(p) => p,
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(2);
            }
        },
        None => VehicleParams::default(),
    };
    let name = params.name.clone();
    let model = Arc::new(VehicleType::new(params));
    let report = run_dyno(&model, &DynoSettings::default());
    if json {
        match serde_json::to_string_pretty(&report) {
            Ok(text) => outln!("{text}"),
            Err(e) => return fail(e),
        }
    } else {
        out!("{}", dyno_table(&name, &report));
    }
    ExitCode::SUCCESS
}

fn dyno_table(name: &str, r: &DynoReport) -> String {
    let t100 = r
        .zero_to_100_kmh_s
        .map_or("not reached".to_owned(), |t| format!("{t:.2} s"));
    format!(
        "dyno: {name}\n\
         \x20 0-100 km/h          {t100}\n\
         \x20 top speed           {:.1} km/h\n\
         \x20 braking 100-0 km/h  {:.1} m\n\
         \x20 max lateral         {:.3} g  (50 m circle)\n\
         \x20 standstill drift    {:.4} m  (60 s, no input)\n",
        r.top_speed_kmh, r.braking_100_0_m, r.max_lateral_g, r.standstill_drift_m
    )
}
