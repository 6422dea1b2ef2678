//! The play session: starting a level from the editor, pausing, stepping, stopping, exporting
//! its telemetry, and the frame clock.

use super::*;

impl AppState {
    /// Play: starts the level as edited (or resumes). Roads still being drawn (a single point)
    /// are left out; anything else `flockway run` would reject is refused, saying what and where.
    pub fn play(&mut self) {
        if let Some(p) = &mut self.play {
            p.paused = false;
            return;
        }
        let (level, drafts) = playable(self.editor.level());
        if let Some(issue) = validate(&level).first() {
            self.status = format!("Cannot play: {}", issue.describe(&level));
            return;
        }
        let name = level_name(&level, self.editor.path().unwrap_or(Path::new("untitled")));
        let csv = std::env::temp_dir().join(format!("flockway-play-{}.csv", std::process::id()));
        match PlaySession::start(level, &name, &self.assets, &csv) {
            Ok(session) => {
                self.edited_level = Some(self.editor.level().clone());
                self.play = Some(session);
                // The scene drops the control-point handles while playing.
                self.scene_version += 1;
                self.selection = Selection::None;
                self.status = match drafts {
                    0 => "Playing.".to_owned(),
                    n => format!("Playing, without {n} road(s) of a single point (not roads yet)."),
                };
            }
            Err(e) => self.status = format!("Cannot play: {e}"),
        }
    }

    /// Pause or resume (Space).
    pub fn toggle_pause(&mut self) {
        if let Some(p) = &mut self.play {
            p.paused = !p.paused;
        }
    }

    /// One fixed step while paused.
    pub fn single_step(&mut self) {
        if let Some(p) = &mut self.play {
            p.paused = true;
            if let Err(e) = p.step_ticks(1) {
                self.status = e.to_string();
            }
        }
    }

    /// Stop: back to the level exactly as edited.
    pub fn stop(&mut self) {
        if self.play.take().is_some() {
            // The editor never saw the run; the check guards against a future change that would.
            debug_assert!(self.edited_level.as_ref() == Some(self.editor.level()));
            self.edited_level = None;
            self.follow = false;
            self.selection = Selection::None;
            self.rebuild_network();
            self.status = "stopped".to_owned();
        }
    }

    /// Writes the run's telemetry CSV to `path` (and its signals CSV beside it).
    pub fn export(&mut self, path: &Path) {
        self.status = match &self.play {
            Some(p) => match p.export_csv(path) {
                Ok(false) => format!("exported {}", path.display()),
                Ok(true) => format!(
                    "exported {} and {}",
                    path.display(),
                    flockway_runner::signals_path(path).display()
                ),
                Err(e) => format!("{}: {e}", path.display()),
            },
            None => "nothing is playing".to_owned(),
        };
    }

    /// Esc: ends the run and exports its CSV next to the level (as in the thesis).
    pub fn end_run(&mut self) {
        if self.play.is_none() {
            self.selection = Selection::None;
            return;
        }
        let stem = self.editor.path().and_then(|p| p.file_stem()).map_or_else(
            || "untitled".to_owned(),
            |s| s.to_string_lossy().into_owned(),
        );
        let dir = self
            .editor
            .path()
            .and_then(Path::parent)
            .map_or_else(|| PathBuf::from("."), Path::to_owned);
        let out = dir.join(format!("{stem}_run.csv"));
        self.export(&out);
        let status = self.status.clone();
        self.stop();
        self.status = status;
    }

    /// Advances play by a frame of `wall_s` seconds.
    pub fn frame(&mut self, wall_s: f64) {
        if let Some(p) = &mut self.play
            && let Err(e) = p.advance(wall_s, FRAME_BUDGET)
        {
            self.status = e.to_string();
            self.play = None;
        }
        if self.follow
            && let (Some(p), Selection::Vehicle(i)) = (&self.play, self.selection)
            && let Some(v) = p.next.instances.get(i)
        {
            self.camera.look_at(Vec3::from_array(v.translation));
        }
    }

    pub(super) fn select_vehicle(&mut self, px: Vec2, size: Vec2) {
        let Some(p) = &self.play else { return };
        let mut best: Option<(f32, usize)> = None;
        for (i, v) in p.next.instances.iter().enumerate() {
            if let Some(s) = self.camera.to_screen(Vec3::from_array(v.translation), size) {
                let d = s.distance(px);
                if d < 20.0 && best.is_none_or(|(bd, _)| d < bd) {
                    best = Some((d, i));
                }
            }
        }
        self.selection = best.map_or(Selection::None, |(_, i)| Selection::Vehicle(i));
    }
}
