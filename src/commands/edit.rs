//! `flockway edit LEVEL --apply EDITS.ron`: a script of editor commands applied headless.

use super::fail;
use flockway::edit::{Editor, apply_script};
use std::path::Path;
use std::process::ExitCode;

/// Applies the edits in `edits` to the level at `level` (all or none) and saves it to `output`
/// (or over `level`), checked as the editor checks every save.
pub fn apply(level: &Path, edits: &Path, output: Option<&Path>) -> ExitCode {
    let mut editor = match Editor::open(level) {
        Ok(e) => e,
        Err(e) => return fail(e),
    };
    let applied = match apply_script(&mut editor, edits) {
        Ok(n) => n,
        Err(e) => return fail(e),
    };
    let out = output.unwrap_or(level);
    match editor.save_as(out) {
        Ok(path) => {
            outln!(
                "applied {applied} edit(s) from {}: wrote {}",
                edits.display(),
                path.display()
            );
            ExitCode::SUCCESS
        }
        Err(e) => fail(e),
    }
}
