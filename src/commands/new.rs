//! `flockway new`: a level from a template, ready to run.

use super::fail;
use flockway::level::{Template, level_to_string, write_atomic};
use std::process::ExitCode;

pub fn new_level(path: &std::path::Path, template: Template) -> ExitCode {
    if path.exists() {
        return fail(format!(
            "{} already exists; `flockway new` never overwrites a file: choose another name",
            path.display()
        ));
    }
    let name = path
        .file_stem()
        .map_or_else(|| "level".to_owned(), |s| s.to_string_lossy().into_owned());
    let level = template.level(&name);
    let text = match level_to_string(&level) {
        Ok(t) => t,
        Err(e) => return fail(e),
    };
    let header = format!(
        "// {name}: made by `flockway new --template {template}`: {}.\n",
        template.summary()
    );
    if let Err(e) = write_atomic(path, format!("{header}{text}").as_bytes()) {
        return fail(e);
    }
    let shown = shell_quote(&path.display().to_string());
    outln!("wrote {} ({})", path.display(), template.summary());
    outln!("run it:   flockway run {shown}");
    outln!("edit it:  flockway edit {shown}");
    ExitCode::SUCCESS
}

/// A path as a shell word: quoted when it holds anything a shell would split or expand.
fn shell_quote(text: &str) -> String {
    let plain = !text.is_empty()
        && text
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "/._-+:=@%,".contains(c));
    if plain {
        text.to_owned()
    } else {
        format!("'{}'", text.replace('\'', "'\\''"))
    }
}
