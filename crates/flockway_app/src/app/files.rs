//! Files: save and save as, actions that ask before discarding changes (new, open, quit), the
//! shipped levels, and the asset files the panels offer.

use super::*;

/// What the panels read from disk, kept so a frame does not list directories or load files.
#[derive(Debug, Default)]
pub(super) struct DiskCache {
    /// The files under each asset subdirectory.
    pub(super) asset_listing: BTreeMap<String, Vec<String>>,
    /// Each driver profile's problem (none: it loads), keyed by the profile's fields.
    pub(super) profile_checks: BTreeMap<String, Option<String>>,
}

impl AppState {
    /// Save (Ctrl+S): to the level's file, or to the file field's path.
    pub fn save(&mut self) -> Result<PathBuf, EditError> {
        let result = match self.editor.path() {
            Some(_) => self.editor.save(),
            None => {
                let path = PathBuf::from(self.file_field.trim());
                self.editor.save_as(&path)
            }
        };
        self.status = match &result {
            Ok(p) => format!("saved {}", p.display()),
            Err(e) => e.to_string(),
        };
        result
    }

    /// Save As: to the file field's path.
    pub fn save_as(&mut self) -> Result<PathBuf, EditError> {
        let path = PathBuf::from(self.file_field.trim());
        let result = self.editor.save_as(&path);
        self.status = match &result {
            Ok(p) => format!("saved {}", p.display()),
            Err(e) => e.to_string(),
        };
        result
    }

    /// Asks for `action`; it happens at once if nothing unsaved would be lost, else it waits
    /// for [`AppState::confirm`].
    pub fn request(&mut self, action: Pending) {
        if self.editor.is_dirty() {
            self.pending = Some(action);
        } else {
            self.do_action(action);
        }
    }

    /// Answers the pending "discard unsaved changes?" question.
    pub fn confirm(&mut self, discard: bool) {
        if let Some(action) = self.pending.take()
            && discard
        {
            self.do_action(action);
        }
    }

    pub(super) fn do_action(&mut self, action: Pending) {
        self.stop();
        // The work is saved or was discarded on purpose: nothing to offer back next time.
        if let Some(auto) = flockway_edit::autosave_path(self.editor.path()) {
            let _ = std::fs::remove_file(auto);
        }
        match action {
            Pending::New => self.load(Editor::new()),
            Pending::Open(path) => match Editor::open(&path) {
                Ok(e) => {
                    self.load(e);
                    self.status = format!("opened {}", path.display());
                }
                Err(e) => self.status = e.to_string(),
            },
            Pending::Quit => self.quit = true,
        }
    }

    pub(super) fn load(&mut self, editor: Editor) {
        self.file_field = editor
            .path()
            .map_or_else(|| "level.ron".to_owned(), |p| p.display().to_string());
        self.editor = editor;
        self.selection = Selection::None;
        self.rebuild_network();
        self.fit_view(16.0 / 9.0);
    }

    /// Number key `n` (1-based): loads the n-th shipped level.
    pub fn load_shipped(&mut self, n: usize) {
        if let Some(path) = self.shipped.get(n.wrapping_sub(1)).cloned() {
            self.request(Pending::Open(path));
        }
    }

    /// The level's file name (or "untitled") and, in play mode, that it is playing.
    pub fn file_label(&self) -> String {
        let name = self.editor.path().and_then(|p| p.file_name()).map_or_else(
            || "untitled".to_owned(),
            |n| n.to_string_lossy().into_owned(),
        );
        let mode = if self.play.is_some() {
            " — playing"
        } else {
            ""
        };
        format!("{name}{mode}")
    }

    /// The window title: file name and `*` when there are unsaved changes.
    pub fn title(&self) -> String {
        let dirty = if self.editor.is_dirty() { "* " } else { "" };
        format!("{dirty}{} — Flockway", self.file_label())
    }

    /// The `.ron` files under `assets/SUB/`, as level paths (`SUB/NAME.ron`), sorted.
    pub fn asset_files(&mut self, sub: &str) -> Vec<String> {
        let assets = self.assets.clone();
        self.disk
            .asset_listing
            .entry(sub.to_owned())
            .or_insert_with(|| {
                let mut files: Vec<String> = std::fs::read_dir(assets.join(sub))
                    .into_iter()
                    .flatten()
                    .filter_map(|e| e.ok())
                    .filter_map(|e| {
                        let name = e.file_name().to_string_lossy().into_owned();
                        name.ends_with(".ron").then(|| format!("{sub}/{name}"))
                    })
                    .collect();
                files.sort();
                files
            })
            .clone()
    }

    /// Why a driver profile cannot drive, if it cannot: its parameter file or an override is
    /// wrong. Profiles of plugin models are left to their plugin.
    pub fn profile_problem(&mut self, profile: &DriverProfileSpec) -> Option<String> {
        let key = format!("{profile:?}");
        if let Some(known) = self.disk.profile_checks.get(&key) {
            return known.clone();
        }
        let mut one = Level::new(1, 1.0);
        one.driver_profiles = vec![profile.clone()];
        let problem = load_driver_profiles(&one, "level", &self.assets)
            .err()
            .map(|e| match e {
                RunError::Driver { name, message, .. } => {
                    format!("driver profile `{name}`: {message}")
                }
                other => other.to_string(),
            });
        if self.disk.profile_checks.len() > 256 {
            self.disk.profile_checks.clear();
        }
        self.disk.profile_checks.insert(key, problem.clone());
        problem
    }
}
