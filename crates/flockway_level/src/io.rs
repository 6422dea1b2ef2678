//! Reading and writing level files: positioned errors on the way in, atomic writes on the way out.

use crate::locate::{Pos, locate};
use crate::schema::Level;
use crate::validate::{validate, warnings};
use serde::Deserialize;
use std::fmt;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Largest level file accepted, in bytes.
pub const MAX_FILE_BYTES: u64 = 64 * 1024 * 1024;
/// Most problems one error report lists, so it fits on a screen.
const MAX_REPORTED: usize = 5;

/// One problem at a place in a level file.
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostic {
    /// Line and column (1-based).
    pub pos: Pos,
    /// What is wrong, and what was expected.
    pub message: String,
}

/// Why a level could not be loaded or saved.
#[derive(Debug, thiserror::Error)]
pub enum LevelError {
    /// The file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The file is too large to be a level.
    #[error("{}: {bytes} bytes is too large for a level (the limit is 64 MiB)", path.display())]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Its size.
        bytes: u64,
    },
    /// The file is not valid RON for a level, or its content is inconsistent.
    #[error("{}", render(path, source_text, diagnostics))]
    Invalid {
        /// The file.
        path: PathBuf,
        /// The file's text, for the excerpt under each message.
        source_text: String,
        /// The problems, in file order (at least one).
        diagnostics: Vec<Diagnostic>,
    },
    /// The level could not be turned into RON (a bug, not a user error).
    #[error("could not write the level as RON: {0}")]
    Serialize(String),
}

impl LevelError {
    /// The positioned problems, if this is a content error.
    pub fn diagnostics(&self) -> &[Diagnostic] {
        match self {
            LevelError::Invalid { diagnostics, .. } => diagnostics,
            _ => &[],
        }
    }
}

fn render(path: &Path, src: &str, diagnostics: &[Diagnostic]) -> String {
    let mut out = String::new();
    for (k, d) in diagnostics.iter().take(MAX_REPORTED).enumerate() {
        if k > 0 {
            out.push('\n');
        }
        out.push_str(&format!(
            "{}:{}:{}: {}",
            path.display(),
            d.pos.line,
            d.pos.col,
            d.message
        ));
        if let Some(line) = src.lines().nth(d.pos.line.saturating_sub(1)) {
            let text: String = line.chars().take(120).collect();
            let gutter = d.pos.line.to_string().len();
            out.push_str(&format!(
                "\n {:>gutter$} | {text}\n {:>gutter$} | {}^",
                d.pos.line,
                "",
                " ".repeat(d.pos.col.saturating_sub(1).min(120))
            ));
        }
    }
    if diagnostics.len() > MAX_REPORTED {
        out.push_str(&format!(
            "\n… and {} more problem(s)",
            diagnostics.len() - MAX_REPORTED
        ));
    }
    out
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}: {}", self.pos.line, self.pos.col, self.message)
    }
}

/// Only the version, read first so that a file from a newer Flockway gets a clear message
/// instead of complaints about fields this build does not know.
#[derive(Deserialize)]
struct VersionProbe {
    version: Option<u32>,
}

/// Parses and validates level text; `path` is only used in messages.
pub fn parse_level(src: &str, path: &Path) -> Result<Level, LevelError> {
    let invalid = |diagnostics: Vec<Diagnostic>| LevelError::Invalid {
        path: path.to_owned(),
        source_text: src.to_owned(),
        diagnostics,
    };
    let options = ron_options();
    if let Ok(VersionProbe { version: Some(v) }) = options.from_str::<VersionProbe>(src)
        && v != crate::CURRENT_VERSION
    {
        let pos = locate(src, &[crate::locate::PathStep::Field("version")]);
        return Err(invalid(vec![Diagnostic {
            pos,
            message: format!(
                "unsupported level version {v}; this Flockway reads version {}",
                crate::CURRENT_VERSION
            ),
        }]));
    }
    let level: Level = options.from_str(src).map_err(|e| {
        let pos = Pos {
            line: e.span.start.line.max(1),
            col: e.span.start.col.max(1),
        };
        invalid(vec![Diagnostic {
            pos,
            message: describe_ron_error(&e.code),
        }])
    })?;
    let issues = validate(&level);
    if issues.is_empty() {
        Ok(level)
    } else {
        let mut diagnostics: Vec<Diagnostic> = issues
            .into_iter()
            .map(|i| Diagnostic {
                pos: locate(src, &i.path),
                message: i.message,
            })
            .collect();
        diagnostics.sort_by_key(|d| d.pos);
        Err(invalid(diagnostics))
    }
}

/// RON's messages, with the ones users meet most often reworded to say what was expected.
/// The level's warnings (see [`crate::warnings`]) as `PATH:LINE:COL: warning: …` lines, placed
/// in its text `src`.
pub fn level_warnings(level: &Level, src: &str, path: &Path) -> Vec<String> {
    let mut found: Vec<Diagnostic> = warnings(level)
        .into_iter()
        .map(|i| Diagnostic {
            pos: locate(src, &i.path),
            message: i.message,
        })
        .collect();
    found.sort_by_key(|d| d.pos);
    found
        .iter()
        .map(|d| {
            format!(
                "{}:{}:{}: warning: {}",
                path.display(),
                d.pos.line,
                d.pos.col,
                d.message
            )
        })
        .collect()
}

fn describe_ron_error(code: &ron::Error) -> String {
    match code {
        ron::Error::Eof => {
            "the file ends too early: a value or a closing bracket is missing".to_owned()
        }
        other => {
            let text = other.to_string();
            let mut chars = text.chars();
            match chars.next() {
                Some(c) => c.to_lowercase().chain(chars).collect(),
                None => text,
            }
        }
    }
}

/// RON options for levels: `implicit_some` lets optional fields be written as plain values
/// (`width_m: 12.0` rather than `width_m: Some(12.0)`); both forms load.
fn ron_options() -> ron::Options {
    ron::Options::default().with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
}

/// Reads, parses and validates a level file.
pub fn load_level(path: &Path) -> Result<Level, LevelError> {
    let io = |source| LevelError::Io {
        path: path.to_owned(),
        source,
    };
    let meta = std::fs::metadata(path).map_err(io)?;
    if meta.len() > MAX_FILE_BYTES {
        return Err(LevelError::TooLarge {
            path: path.to_owned(),
            bytes: meta.len(),
        });
    }
    let bytes = std::fs::read(path).map_err(io)?;
    let src = String::from_utf8(bytes).map_err(|e| {
        let valid = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        let text = String::from_utf8_lossy(valid);
        let line = text.matches('\n').count() + 1;
        let col = text.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
        LevelError::Invalid {
            path: path.to_owned(),
            source_text: text.into_owned(),
            diagnostics: vec![Diagnostic {
                pos: Pos { line, col },
                message: "the file is not UTF-8 text".to_owned(),
            }],
        }
    })?;
    parse_level(&src, path)
}

/// The RON text of a level, as [`save_level`] writes it.
pub fn level_to_string(level: &Level) -> Result<String, LevelError> {
    // Depth 4 keeps each control point, spawner and trigger on one line: diffs stay readable.
    let config = ron::ser::PrettyConfig::new()
        .depth_limit(4)
        .struct_names(false)
        .separate_tuple_members(false)
        .extensions(ron::extensions::Extensions::IMPLICIT_SOME);
    let mut text = ron::ser::to_string_pretty(level, config)
        .map_err(|e| LevelError::Serialize(e.to_string()))?;
    text.push('\n');
    Ok(text)
}

/// Writes a level atomically: to a temporary file beside the target, flushed to disk, then renamed
/// over it, so a crash mid-save leaves either the old file or the new one, never half of one.
pub fn save_level(level: &Level, path: &Path) -> Result<(), LevelError> {
    let text = level_to_string(level)?;
    write_atomic(path, text.as_bytes())
}

/// Writes `bytes` to `path` atomically (temporary file, sync, rename).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), LevelError> {
    let io = |source| LevelError::Io {
        path: path.to_owned(),
        source,
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_owned(),
        _ => PathBuf::from("."),
    };
    let name = path.file_name().ok_or_else(|| {
        io(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a file path",
        ))
    })?;
    let tmp = dir.join(format!(
        ".{}.tmp-{}",
        name.to_string_lossy(),
        std::process::id()
    ));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        drop(f);
        std::fs::rename(&tmp, path)?;
        // Make the rename itself durable where the platform allows syncing a directory.
        if let Ok(d) = std::fs::File::open(&dir) {
            let _ = d.sync_all();
        }
        Ok(())
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map_err(io)
}
