//! Where a level's files are and what they hold: the `assets/` directory, the vehicle types
//! and the driver profiles a level names.

use crate::runner::RunError;
use flockway_drivers::{BuiltinModel, DriverSpec};
use flockway_level::{DriverModel, Level};
use flockway_vehicle::{VehicleParams, VehicleType};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Environment variable that overrides where `assets/` is.
pub const ASSETS_ENV: &str = "FLOCKWAY_ASSETS";

/// Finds the `assets/` directory for a level: `$FLOCKWAY_ASSETS` if set, else the nearest
/// `assets/` in the level's directory or one of its parents, else `./assets`, else the one in
/// the source tree this program was built from.
pub fn find_assets_dir(level_path: Option<&Path>) -> PathBuf {
    if let Some(dir) = std::env::var_os(ASSETS_ENV) {
        return PathBuf::from(dir);
    }
    if let Some(path) = level_path {
        let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_owned());
        for dir in abs.ancestors().skip(1) {
            let candidate = dir.join("assets");
            if candidate.is_dir() {
                return candidate;
            }
        }
    }
    let cwd = PathBuf::from("assets");
    if cwd.is_dir() {
        return cwd;
    }
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets")
}

/// Loads and validates every vehicle type a level names, by name.
pub fn load_vehicle_types(
    level: &Level,
    level_name: &str,
    assets: &Path,
) -> Result<BTreeMap<String, Arc<VehicleType>>, RunError> {
    level
        .vehicle_types
        .iter()
        .map(|v| {
            let params =
                VehicleParams::load(&assets.join(&v.path)).map_err(|source| RunError::Vehicle {
                    level: level_name.to_owned(),
                    name: v.name.clone(),
                    source,
                })?;
            Ok((v.name.clone(), Arc::new(VehicleType::new(params))))
        })
        .collect()
}

/// Builds every driver profile a level defines, by name: the built-in model's parameters from
/// the profile's file under `assets/` (or the model's defaults) with its `set` overrides.
/// Profiles of plugin models (`Custom`) are left to their plugin and not listed.
pub fn load_driver_profiles(
    level: &Level,
    level_name: &str,
    assets: &Path,
) -> Result<BTreeMap<String, DriverSpec>, RunError> {
    load_profiles(level, level_name, assets, false)
}

/// [`load_driver_profiles`], and with `external` the profiles of custom models too, as
/// [`DriverSpec::Custom`] (driven from outside the step, a lane-keeping flocking car with the
/// profile's `FlockLanes` parameters until told otherwise).
pub fn load_profiles(
    level: &Level,
    level_name: &str,
    assets: &Path,
    external: bool,
) -> Result<BTreeMap<String, DriverSpec>, RunError> {
    let mut out = BTreeMap::new();
    for profile in &level.driver_profiles {
        let fail = |message: String| RunError::Driver {
            level: level_name.to_owned(),
            name: profile.name.clone(),
            message,
        };
        // A custom model's profile is left to the plugin of that name (or driven externally).
        let model = match builtin_model(&profile.model) {
            Ok(model) => Ok(model),
            Err(_) if !external => continue,
            Err(name) => Err(name),
        };
        let text = match &profile.params {
            Some(rel) => {
                let path = assets.join(rel);
                let text = std::fs::read_to_string(&path)
                    .map_err(|e| fail(format!("{}: {e}", path.display())))?;
                Some((path.display().to_string(), text))
            }
            None => None,
        };
        let params = text.as_ref().map(|(p, t)| (p.as_str(), t.as_str()));
        let spec = match model {
            Ok(model) => DriverSpec::build(model, params, &profile.set),
            Err(name) => DriverSpec::custom(&name, params, &profile.set),
        }
        .map_err(|e| fail(e.to_string()))?;
        out.insert(profile.name.clone(), spec);
    }
    Ok(out)
}

/// The level's driver profiles, built, by name.
#[derive(bevy_ecs::resource::Resource, Debug, Clone, Default)]
pub struct DriverProfiles(pub BTreeMap<String, DriverSpec>);

/// The level's vehicle types, loaded from `assets/`, by name.
#[derive(bevy_ecs::resource::Resource, Debug, Clone, Default)]
pub struct VehicleTypes(pub BTreeMap<String, Arc<VehicleType>>);

/// The built-in model a level names; a `Custom` model is a plugin's, named in the error.
pub fn builtin_model(m: &DriverModel) -> Result<BuiltinModel, String> {
    Ok(match m {
        DriverModel::Flock => BuiltinModel::Flock,
        DriverModel::FlockLanes => BuiltinModel::FlockLanes,
        DriverModel::Human => BuiltinModel::Human,
        DriverModel::Idm => BuiltinModel::Idm,
        DriverModel::WaveDamper => BuiltinModel::WaveDamper,
        DriverModel::Custom(name) => return Err(name.clone()),
    })
}

/// How a level file names a built-in model.
pub fn level_model(m: BuiltinModel) -> DriverModel {
    match m {
        BuiltinModel::Flock => DriverModel::Flock,
        BuiltinModel::FlockLanes => DriverModel::FlockLanes,
        BuiltinModel::Human => DriverModel::Human,
        BuiltinModel::Idm => DriverModel::Idm,
        BuiltinModel::WaveDamper => DriverModel::WaveDamper,
    }
}
