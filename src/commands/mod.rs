//! One module per command: each turns its arguments into calls on the library crates and their
//! outcome into output and an exit status.

pub mod analysis;
pub mod check;
pub mod dyno;
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
