//! `flockway.Level`'s native half: a level file edited headless through the editor's model
//! (`flockway_edit`), with the same commands, checks and undo as the window's editor.

use flockway_edit::{Command, EditError, Editor};
use pyo3::exceptions::{PyFileNotFoundError, PyValueError};
use pyo3::prelude::*;
use std::path::{Path, PathBuf};

/// An edit or save refused: a missing file is `FileNotFoundError`, anything else `ValueError`
/// with the editor's message.
fn edit_error(e: EditError) -> PyErr {
    let message = e.to_string();
    match e {
        EditError::File(flockway_level::LevelError::Io { source, .. })
            if source.kind() == std::io::ErrorKind::NotFound =>
        {
            PyFileNotFoundError::new_err(message)
        }
        _ => PyValueError::new_err(message),
    }
}

/// A level being edited (see `flockway.Level` for the documented API).
#[pyclass(module = "flockway._flockway", name = "LevelDoc")]
pub struct PyLevel {
    editor: Editor,
}

#[pymethods]
impl PyLevel {
    /// Opens the level file at `path`, or a new empty level (the `empty` template) without one.
    #[new]
    #[pyo3(signature = (path=None))]
    fn new(path: Option<PathBuf>) -> PyResult<PyLevel> {
        let editor = match path {
            Some(p) => Editor::open(&p).map_err(edit_error)?,
            None => Editor::new(),
        };
        Ok(PyLevel { editor })
    }

    /// Applies one command written in RON (`Set(item: Road("main"), field: "lanes", value: 3)`)
    /// or, with `json`, in JSON (`{"Set": {"item": {"Road": "main"}, …}}`), as one undo step.
    #[pyo3(signature = (text, json=false))]
    fn apply(&mut self, text: &str, json: bool) -> PyResult<()> {
        let command: Command = if json {
            serde_json::from_str(text)
                .map_err(|e| PyValueError::new_err(format!("not an edit command: {e}")))?
        } else {
            ron::Options::default()
                .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
                .from_str(text)
                .map_err(|e| PyValueError::new_err(format!("not an edit command: {e}")))?
        };
        self.editor.apply(command).map_err(edit_error)
    }

    /// Undoes the last edit; false if there is none.
    fn undo(&mut self) -> bool {
        self.editor.undo()
    }

    /// Redoes the last undone edit; false if there is none.
    fn redo(&mut self) -> bool {
        self.editor.redo()
    }

    /// What undo would undo, if anything.
    #[getter]
    fn undo_label(&self) -> Option<String> {
        self.editor.undo_label().map(str::to_owned)
    }

    /// Saves (atomically) to `path`, or to the file it was opened from; refuses a level
    /// `flockway run` would reject. Returns the path written.
    #[pyo3(signature = (path=None))]
    fn save(&mut self, path: Option<PathBuf>) -> PyResult<PathBuf> {
        match path {
            Some(p) => self.editor.save_as(&p),
            None => self.editor.save(),
        }
        .map_err(edit_error)
    }

    /// The level's RON text, checked as a save is (`path` names it in messages).
    fn checked_text(&self, path: PathBuf) -> PyResult<String> {
        self.editor.checked_text(&path).map_err(edit_error)
    }

    /// The level as JSON (every field, as the level file has it).
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string(self.editor.level()).map_err(|e| PyValueError::new_err(e.to_string()))
    }

    /// The file it was opened from or last saved to.
    #[getter]
    fn path(&self) -> Option<PathBuf> {
        self.editor.path().map(Path::to_path_buf)
    }

    /// Whether there are edits not saved.
    #[getter]
    fn dirty(&self) -> bool {
        self.editor.is_dirty()
    }
}
