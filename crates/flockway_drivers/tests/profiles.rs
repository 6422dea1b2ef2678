//! The shipped driver profiles in `assets/drivers/` load and are exactly the built-in defaults.

use flockway_drivers::{BuiltinModel, DriverSpec};
use std::collections::BTreeMap;
use std::path::Path;

#[test]
fn shipped_profiles_are_the_defaults() {
    let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets");
    for model in BuiltinModel::ALL {
        let path = assets.join(model.default_params_path());
        let text =
            std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let spec = DriverSpec::build(
            model,
            Some((&path.display().to_string(), &text)),
            &BTreeMap::new(),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            spec,
            DriverSpec::default_for(model),
            "{} drifted from the defaults",
            path.display()
        );
    }
}
