//! One module per command: each turns its arguments into calls on the library crates and their
//! outcome into output and an exit status.

pub mod analysis;
pub mod check;
pub mod compare;
pub mod dyno;
pub mod edit;
pub mod import;
pub mod new;
pub mod run;
pub mod test;
pub mod window;

use std::process::ExitCode;

/// Prints `error: …` and returns exit status 2 (bad input).
pub fn fail(e: impl std::fmt::Display) -> ExitCode {
    eprintln!("error: {e}");
    ExitCode::from(2)
}

/// Prints a level file's warnings (a road leading nowhere, …) to stderr.
pub(crate) fn print_warnings(level: &flockway::level::Level, path: &std::path::Path) {
    let Ok(src) = std::fs::read_to_string(path) else {
        return;
    };
    for w in flockway::level::level_warnings(level, &src, path) {
        eprintln!("{w}");
    }
}
