//! Scripts of edits: a RON list of [`Command`]s (the same serde types the editor applies),
//! applied to a level all or none, with the failing edit's position in the file.

use crate::command::Command;
use crate::editor::Editor;
use crate::error::EditError;
use std::path::{Path, PathBuf};

/// Why a script of edits was not applied. The level is as it was before the script.
#[derive(Debug, thiserror::Error)]
pub enum ScriptError {
    /// The file could not be read.
    #[error("{}: cannot read: {source}", path.display())]
    Read {
        /// The script.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The text is not a list of edits.
    #[error("{}:{line}:{col}: {message} (expected a list of edits, e.g. `[SetRoad(road: 0, …)]`)", path.display())]
    Parse {
        /// The script.
        path: PathBuf,
        /// Line, from 1.
        line: usize,
        /// Column, from 1.
        col: usize,
        /// What the parser said.
        message: String,
    },
    /// An edit was refused.
    #[error("{}:{line}:{col}: edit {number} of {count} ({label}) refused: {source}", path.display())]
    Refused {
        /// The script.
        path: PathBuf,
        /// Line of the edit, from 1.
        line: usize,
        /// Its column, from 1.
        col: usize,
        /// Its position in the list, from 1.
        number: usize,
        /// How many edits the script holds.
        count: usize,
        /// What the edit does.
        label: String,
        /// Why it was refused.
        source: Box<EditError>,
    },
}

impl ScriptError {
    /// The position (from 1) of the edit that was refused, if one was.
    pub fn edit_number(&self) -> Option<usize> {
        match self {
            ScriptError::Refused { number, .. } => Some(*number),
            _ => None,
        }
    }
}

/// The line and column (from 1) where each element of the top-level list in `text` starts,
/// skipping strings and comments, so an edit's error can point at it.
fn element_starts(text: &str) -> Vec<(usize, usize)> {
    let mut starts = Vec::new();
    let (mut depth, mut line, mut col) = (0usize, 1usize, 1usize);
    let mut expecting = false;
    let mut chars = text.chars().peekable();
    let mut in_string = false;
    while let Some(c) = chars.next() {
        let here = (line, col);
        if c == '\n' {
            line += 1;
            col = 1;
        } else {
            col += 1;
        }
        if in_string {
            match c {
                '\\' if chars.next().is_some() => col += 1,
                '"' => in_string = false,
                _ => {}
            }
            continue;
        }
        if c == '/' && chars.peek() == Some(&'/') {
            for d in chars.by_ref() {
                if d == '\n' {
                    line += 1;
                    col = 1;
                    break;
                }
            }
            continue;
        }
        if c == '/' && chars.peek() == Some(&'*') {
            chars.next();
            col += 1;
            let mut last = ' ';
            for d in chars.by_ref() {
                if d == '\n' {
                    line += 1;
                    col = 1;
                } else {
                    col += 1;
                }
                if last == '*' && d == '/' {
                    break;
                }
                last = d;
            }
            continue;
        }
        if c.is_whitespace() {
            continue;
        }
        if expecting && !(depth == 1 && c == ']') {
            starts.push(here);
            expecting = false;
        }
        match c {
            '"' => in_string = true,
            '[' | '(' | '{' => {
                depth += 1;
                if depth == 1 {
                    expecting = true;
                }
            }
            ']' | ')' | '}' => depth = depth.saturating_sub(1),
            ',' if depth == 1 => expecting = true,
            _ => {}
        }
    }
    starts
}

/// Parses a script's text: a RON list of edits. `path` names the file in errors.
pub fn parse_script(text: &str, path: &Path) -> Result<Vec<Command>, ScriptError> {
    ron::Options::default()
        .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
        .from_str::<Vec<Command>>(text)
        .map_err(|e| ScriptError::Parse {
            path: path.to_owned(),
            line: e.span.start.line,
            col: e.span.start.col,
            message: e.code.to_string(),
        })
}

/// Applies the edits in the script at `path` to `editor`, all or none: each is checked as the
/// window's edits are; on the first refused one the level is left as it was and the error
/// names that edit's position. Returns how many edits were applied.
pub fn apply_script(editor: &mut Editor, path: &Path) -> Result<usize, ScriptError> {
    let text = std::fs::read_to_string(path).map_err(|source| ScriptError::Read {
        path: path.to_owned(),
        source,
    })?;
    let commands = parse_script(&text, path)?;
    let starts = element_starts(&text);
    let mut work = editor.clone();
    let count = commands.len();
    for (k, command) in commands.into_iter().enumerate() {
        let label = command.label().to_owned();
        if let Err(source) = work.apply(command) {
            let (line, col) = starts.get(k).copied().unwrap_or((1, 1));
            return Err(ScriptError::Refused {
                path: path.to_owned(),
                line,
                col,
                number: k + 1,
                count,
                label,
                source: Box::new(source),
            });
        }
    }
    *editor = work;
    Ok(count)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn element_starts_skip_strings_comments_and_nesting() {
        let text = "// edits\n[\n  A(x: \"a, [b]\"), /* (, */ B((1, 2)),\n  C,\n]\n";
        assert_eq!(element_starts(text), vec![(3, 3), (3, 28), (4, 3)]);
        assert_eq!(element_starts("[]"), Vec::<(usize, usize)>::new());
        assert_eq!(element_starts("[A, B,]"), vec![(1, 2), (1, 5)]);
    }
}
